#pragma once

#include <atomic>
#include <condition_variable>
#include <memory>
#include <mutex>
#include <set>
#include <string>
#include <thread>

#include "server/web_api.h"

// The HTTP(S) listener of ves-server (--http HOST:PORT, docs/web.md):
// Boost.Beast on Boost.Asio, one thread per connection (bounded), TLS with
// the server's certificate when it has one, plaintext only on loopback.
namespace ves::server {

struct HttpOptions {
  std::string listen;         // host:port; port 0 picks a free one
  std::string tls_cert_file;  // PEM; with tls_key_file: HTTPS
  std::string tls_key_file;
  int max_connections = 128;
  int io_timeout_s = 30;  // a connection idle this long (or a slow request) is closed
  bool log_calls = true;  // one spdlog line per request
  OidcConfig oidc = {};   // sign-in through the identity provider (docs/web.md)
};

class HttpServer {
 public:
  HttpServer(HttpOptions options, ServiceDeps deps);
  ~HttpServer();
  // Throws std::invalid_argument for plaintext off loopback or bad TLS files,
  // std::runtime_error when the address cannot be bound.
  void Start();
  int port() const { return port_; }
  bool tls() const { return !options_.tls_cert_file.empty(); }
  // Closes the listener and every connection; waits for their threads.
  void Stop();

  struct Impl;  // sockets and threads (http_server.cc)

 private:
  HttpOptions options_;
  std::unique_ptr<WebApi> api_;
  std::unique_ptr<Impl> impl_;
  int port_ = 0;
};

}  // namespace ves::server
