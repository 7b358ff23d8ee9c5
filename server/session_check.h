#pragma once

#include <string>

#include "ves/v1/session.pb.h"

// What the server requires of an uploaded SessionRecord before it is stored
// (docs/server.md). Pure: no store, no gRPC.
namespace ves::server {

// Empty when acceptable; otherwise one line naming the field and the value,
// e.g. "record.metrics.pain_s = nan: must be finite".
std::string CheckSessionRecord(const ves::v1::SessionRecord& record);

// Lower-case RFC 4122 text form: 8-4-4-4-12 hex digits.
bool IsLowerCaseUuid(const std::string& text);

}  // namespace ves::server
