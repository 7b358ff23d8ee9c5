#pragma once

#include <map>
#include <string>
#include <utility>
#include <vector>

// A small HTTP/1.1 client over Boost.Beast for the web API tests and
// benchmarks (loopback only).
namespace ves::server::testing {

struct HttpResult {
  int status = 0;
  std::string body;
  std::multimap<std::string, std::string> headers;  // names in lower case
  std::string Header(const std::string& lower_name) const {
    auto it = headers.find(lower_name);
    return it == headers.end() ? std::string() : it->second;
  }
};

using Headers = std::vector<std::pair<std::string, std::string>>;

// One request on a fresh connection; `tls` speaks HTTPS without verifying the
// certificate (tests make their own). Throws on a transport error.
HttpResult HttpCall(int port, const std::string& method, const std::string& target,
                    const Headers& headers = {}, const std::string& body = "", bool tls = false);

// A raw request as bytes (for malformed or oversized requests); the reply's
// status line and body.
HttpResult HttpRaw(int port, const std::string& bytes);

}  // namespace ves::server::testing
