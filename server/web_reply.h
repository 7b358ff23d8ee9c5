#pragma once

#include <grpcpp/grpcpp.h>

#include <cstdint>
#include <map>
#include <nlohmann/json_fwd.hpp>
#include <string>

#include "server/web_api.h"

// The HTTP API's reply and query helpers (server/web_api.cc), shared by the
// route files of the web layer (server/web_cohort.cc) so that every route
// answers errors and reads numbers the same way (docs/web.md).
namespace ves::server {

HttpReply JsonReply(int status, const nlohmann::json& body);
// {"error": {"code": CODE, "message": MESSAGE}} with that HTTP status.
HttpReply Error(int status, const std::string& code, const std::string& message);
HttpReply ErrorOf(const grpc::Status& s);

// Unsigned query number in [0, max] (absent: *value untouched); false with
// a 400 in *error naming the parameter.
bool QueryNumber(const std::map<std::string, std::string>& q, const std::string& name,
                 uint64_t max, uint64_t* value, HttpReply* error);
// from_unix_ms and to_unix_ms (0: no bound), to after from; false with a 400.
bool QueryTimeRange(const std::map<std::string, std::string>& q, int64_t* from_unix_ms,
                    int64_t* to_unix_ms, HttpReply* error);

// A file name part for Content-Disposition: letters, digits, '.', '-', '_'
// kept, anything else '_', at most 64.
std::string FileNamePart(const std::string& id);

}  // namespace ves::server
