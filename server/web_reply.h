#pragma once

#include <google/protobuf/message.h>
#include <grpcpp/grpcpp.h>

#include <cstdint>
#include <map>
#include <nlohmann/json_fwd.hpp>
#include <string>
#include <string_view>
#include <vector>

#include "server/web_api.h"

// The HTTP API's reply, query and text helpers (server/web_reply.cc), shared
// by the route files of the web layer so that every route answers errors and
// reads numbers the same way (docs/web.md).
namespace ves::server {

HttpReply JsonReply(int status, const nlohmann::json& body);
// {"error": {"code": CODE, "message": MESSAGE}} with that HTTP status.
HttpReply Error(int status, const std::string& code, const std::string& message);
HttpReply ErrorOf(const grpc::Status& s);

// A proto message as JSON: field names as in the .proto, defaults printed.
nlohmann::json ProtoJson(const google::protobuf::Message& m);

// Percent-decoding ('+' as a space when `plus_is_space`); false on a broken escape.
bool PercentDecode(std::string_view in, std::string* out, bool plus_is_space);
// `s` cut at every `sep` (n separators: n + 1 parts).
std::vector<std::string> SplitText(std::string_view s, char sep);
// The value of cookie `name` in a Cookie header ("" when absent).
std::string CookieValue(const std::string& header, const std::string& name);

// Unsigned query number in [0, max] (absent: *value untouched); false with
// a 400 in *error naming the parameter.
bool QueryNumber(const std::map<std::string, std::string>& q, const std::string& name,
                 uint64_t max, uint64_t* value, HttpReply* error);
// from_unix_ms and to_unix_ms (0: no bound), to after from; false with a 400.
bool QueryTimeRange(const std::map<std::string, std::string>& q, int64_t* from_unix_ms,
                    int64_t* to_unix_ms, HttpReply* error);
// A query parameter's text; "" when absent.
std::string QueryText(const std::map<std::string, std::string>& q, const std::string& name);

// A file name part for Content-Disposition: letters, digits, '.', '-', '_'
// kept, anything else '_', at most 64.
std::string FileNamePart(const std::string& id);

}  // namespace ves::server
