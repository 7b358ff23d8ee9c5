#pragma once

#include <string>
#include <string_view>

#include "ves/v1/case.pb.h"

// The authoring format: protobuf text format of ves.v1.ColonCase.
namespace ves::patient_db {

// Parses text format; throws CaseError naming the line and column of every
// syntax error. Does not validate (see ValidateCase).
ves::v1::ColonCase ParseCaseTextproto(std::string_view text, const std::string& file_label);

// Text format with a header comment naming the message; deterministic.
std::string FormatCaseTextproto(const ves::v1::ColonCase& colon_case);

}  // namespace ves::patient_db
