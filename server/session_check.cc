#include "server/session_check.h"

#include <google/protobuf/descriptor.h>
#include <google/protobuf/message.h>

#include <cmath>

namespace ves::server {
namespace {

using google::protobuf::FieldDescriptor;
using google::protobuf::Message;

std::string FormatDouble(double v) {
  if (std::isnan(v)) return "nan";
  if (std::isinf(v)) return v > 0 ? "inf" : "-inf";
  return std::to_string(v);
}

// The first non-finite double or float anywhere in `m`, as "path = value".
std::string FindNonFinite(const Message& m, const std::string& path) {
  const auto* d = m.GetDescriptor();
  const auto* r = m.GetReflection();
  for (int i = 0; i < d->field_count(); ++i) {
    const FieldDescriptor* f = d->field(i);
    const std::string name = path + "." + f->name();
    const bool is_double = f->cpp_type() == FieldDescriptor::CPPTYPE_DOUBLE;
    const bool is_float = f->cpp_type() == FieldDescriptor::CPPTYPE_FLOAT;
    const bool is_message = f->cpp_type() == FieldDescriptor::CPPTYPE_MESSAGE;
    if (f->is_repeated()) {
      const int n = r->FieldSize(m, f);
      for (int k = 0; k < n; ++k) {
        const std::string item = name + "[" + std::to_string(k) + "]";
        double v = 0;
        if (is_double) v = r->GetRepeatedDouble(m, f, k);
        if (is_float) v = r->GetRepeatedFloat(m, f, k);
        if ((is_double || is_float) && !std::isfinite(v)) return item + " = " + FormatDouble(v);
        if (is_message) {
          std::string found = FindNonFinite(r->GetRepeatedMessage(m, f, k), item);
          if (!found.empty()) return found;
        }
      }
      continue;
    }
    double v = 0;
    if (is_double) v = r->GetDouble(m, f);
    if (is_float) v = r->GetFloat(m, f);
    if ((is_double || is_float) && !std::isfinite(v)) return name + " = " + FormatDouble(v);
    if (is_message && r->HasField(m, f)) {
      std::string found = FindNonFinite(r->GetMessage(m, f), name);
      if (!found.empty()) return found;
    }
  }
  return {};
}

bool IsIdText(const std::string& s) {
  if (s.empty() || s.size() > 128) return false;
  for (char c : s) {
    if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) return false;
  }
  return true;
}

}  // namespace

bool IsLowerCaseUuid(const std::string& text) {
  if (text.size() != 36) return false;
  for (size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (i == 8 || i == 13 || i == 18 || i == 23) {
      if (c != '-') return false;
    } else if (!((c >= '0' && c <= '9') || (c >= 'a' && c <= 'f'))) {
      return false;
    }
  }
  return true;
}

std::string CheckSessionRecord(const ves::v1::SessionRecord& record) {
  if (!IsLowerCaseUuid(record.uuid())) {
    return "record.uuid = '" + record.uuid() + "': must be a lower-case RFC 4122 UUID";
  }
  if (!IsIdText(record.trainee_id())) {
    return "record.trainee_id = '" + record.trainee_id() + "': must be 1..128 printable characters";
  }
  if (!IsIdText(record.case_id())) {
    return "record.case_id = '" + record.case_id() + "': must be 1..128 printable characters";
  }
  std::string non_finite = FindNonFinite(record, "record");
  if (!non_finite.empty()) return non_finite + ": must be finite";
  if (record.score() < 0 || record.score() > 100) {
    return "record.score = " + FormatDouble(record.score()) + ": must be in [0, 100]";
  }
  if (record.end_unix_ms() < record.start_unix_ms()) {
    return "record.end_unix_ms = " + std::to_string(record.end_unix_ms()) +
           ": before start_unix_ms " + std::to_string(record.start_unix_ms());
  }
  return {};
}

}  // namespace ves::server
