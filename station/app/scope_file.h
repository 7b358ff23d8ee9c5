#pragma once

#include <string>

#include "ves/v1/endoscope.pb.h"

namespace ves::station {

// Reads an EndoscopeSpec textproto (`--scope FILE`); throws
// std::invalid_argument naming the file when it is unreadable or malformed.
ves::v1::EndoscopeSpec ReadScopeFile(const std::string& path);

}  // namespace ves::station
