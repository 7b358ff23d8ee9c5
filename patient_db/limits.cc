#include "patient_db/limits.h"

#include <cstdio>
#include <map>
#include <set>

namespace ves::patient_db {
namespace {

using google::protobuf::FieldDescriptor;
using google::protobuf::Message;

bool EndsWith(std::string_view s, std::string_view suffix) {
  return s.size() >= suffix.size() && s.substr(s.size() - suffix.size()) == suffix;
}

// Fields whose limit is not their name's rule (LimitOf), by full name.
const std::map<std::string, FieldLimit, std::less<>>& NamedLimits() {
  static const std::map<std::string, FieldLimit, std::less<>> kNamed = {
      {"ves.v1.InputLog.encoded", {FieldKind::kBytes, kMaxInputLogBytes}},
      {"ves.v1.MucosaTexture.image", {FieldKind::kBytes, kMaxTextureBytes}},
      {"ves.v1.CaseChunk.data", {FieldKind::kBytes, kMaxChunkBytes}},
      {"ves.v1.UploadCaseRequest.chunk", {FieldKind::kBytes, kMaxChunkBytes}},
      {"ves.v1.LiveFrame.endoscope_jpeg", {FieldKind::kBytes, kMaxLiveJpegBytes}},
      {"ves.v1.CreateTokenResponse.token", {FieldKind::kHex, kMaxHexBytes}},
      {"ves.v1.CreateTokenResponse.token_id", {FieldKind::kHex, kMaxHexBytes}},
  };
  return kNamed;
}

const std::map<std::string, int, std::less<>>& NamedItemLimits() {
  static const std::map<std::string, int, std::less<>> kNamed = {
      {"ves.v1.ColonCase.centerline", kMaxCasePoints},
      {"ves.v1.ColonCase.radius_profile", kMaxCasePoints},
      {"ves.v1.ColonCase.regions", kMaxCaseRegions},
      {"ves.v1.SessionRecord.events", kMaxSessionEvents},
      {"ves.v1.Curriculum.lessons", kMaxCurriculumLessons},
      {"ves.v1.Lesson.prerequisites", kMaxCurriculumLessons},
      {"ves.v1.LessonVerdict.checks", 64},
      {"ves.v1.CaseSummary.regions", 16},
  };
  return kNamed;
}

// Length in bytes of the UTF-8 sequence starting at text[i], 0 when invalid.
std::size_t Utf8SequenceAt(std::string_view text, std::size_t i, std::uint32_t* code_point) {
  const auto byte = [&](std::size_t k) { return static_cast<unsigned char>(text[k]); };
  const unsigned char b0 = byte(i);
  std::size_t n = 0;
  std::uint32_t cp = 0;
  if (b0 < 0x80) {
    *code_point = b0;
    return 1;
  } else if (b0 >= 0xc2 && b0 <= 0xdf) {
    n = 2;
    cp = b0 & 0x1f;
  } else if (b0 >= 0xe0 && b0 <= 0xef) {
    n = 3;
    cp = b0 & 0x0f;
  } else if (b0 >= 0xf0 && b0 <= 0xf4) {
    n = 4;
    cp = b0 & 0x07;
  } else {
    return 0;
  }
  if (i + n > text.size()) return 0;
  for (std::size_t k = 1; k < n; ++k) {
    if ((byte(i + k) & 0xc0) != 0x80) return 0;
    cp = (cp << 6) | (byte(i + k) & 0x3f);
  }
  // Overlong forms, surrogates and code points past U+10FFFF.
  if ((n == 3 && cp < 0x800) || (n == 4 && cp < 0x10000) || cp > 0x10ffff ||
      (cp >= 0xd800 && cp <= 0xdfff)) {
    return 0;
  }
  *code_point = cp;
  return n;
}

bool IsControl(std::uint32_t cp) { return cp < 0x20 || (cp >= 0x7f && cp <= 0x9f); }

// Empty when `value` suits `limit`; else why not.
std::string CheckText(std::string_view value, const FieldLimit& limit) {
  if (value.size() > limit.max_bytes) {
    return std::to_string(value.size()) + " bytes, more than " + std::to_string(limit.max_bytes);
  }
  switch (limit.kind) {
    case FieldKind::kBytes:
      return {};
    case FieldKind::kHex:
      for (char c : value) {
        if (!((c >= '0' && c <= '9') || (c >= 'a' && c <= 'f'))) return "not lower-case hex";
      }
      return {};
    case FieldKind::kId:
    case FieldKind::kName:
    case FieldKind::kText:
      break;
  }
  const bool newlines = limit.kind == FieldKind::kText;
  for (std::size_t i = 0; i < value.size();) {
    std::uint32_t cp = 0;
    const std::size_t n = Utf8SequenceAt(value, i, &cp);
    if (n == 0) return "not valid UTF-8 (byte " + std::to_string(i) + ")";
    if (IsControl(cp) && !(newlines && (cp == '\n' || cp == '\t'))) {
      char code[16];
      std::snprintf(code, sizeof code, "U+%04X", static_cast<unsigned>(cp));
      return std::string("control character ") + code;
    }
    i += n;
  }
  return {};
}

// True (and *out filled) at the first field of `m` over its limit.
bool CheckFields(const Message& m, const std::string& path, int depth, LimitProblem* out) {
  if (depth > 16) {
    *out = {path, "", "nested too deep"};
    return true;
  }
  const auto* d = m.GetDescriptor();
  const auto* r = m.GetReflection();
  for (int i = 0; i < d->field_count(); ++i) {
    const FieldDescriptor* f = d->field(i);
    const std::string name = path + "." + f->name();
    const bool is_string = f->cpp_type() == FieldDescriptor::CPPTYPE_STRING;
    const bool is_message = f->cpp_type() == FieldDescriptor::CPPTYPE_MESSAGE;
    if (f->is_repeated()) {
      const int n = r->FieldSize(m, f);
      const int max_items = LimitItemsOf(*f);
      if (n > max_items) {
        *out = {name, "",
                std::to_string(n) + " items, more than " + std::to_string(max_items)};
        return true;
      }
      if (!is_string && !is_message) continue;
      const FieldLimit limit = is_string ? LimitOf(*f) : FieldLimit{};
      for (int k = 0; k < n; ++k) {
        const std::string item = name + "[" + std::to_string(k) + "]";
        if (is_string) {
          std::string scratch;
          const std::string& v = r->GetRepeatedStringReference(m, f, k, &scratch);
          const std::string why = CheckText(v, limit);
          if (!why.empty()) {
            *out = {item, PrintableExcerpt(v, 32), why, true};
            return true;
          }
        } else if (CheckFields(r->GetRepeatedMessage(m, f, k), item, depth + 1, out)) {
          return true;
        }
      }
      continue;
    }
    if (is_string) {
      std::string scratch;
      const std::string& v = r->GetStringReference(m, f, &scratch);
      const std::string why = CheckText(v, LimitOf(*f));
      if (!why.empty()) {
        *out = {name, PrintableExcerpt(v, 32), why, true};
        return true;
      }
    } else if (is_message && r->HasField(m, f) &&
               CheckFields(r->GetMessage(m, f), name, depth + 1, out)) {
      return true;
    }
  }
  return false;
}

}  // namespace

FieldLimit LimitOf(const FieldDescriptor& field) {
  const auto named = NamedLimits().find(field.full_name());
  if (named != NamedLimits().end()) return named->second;
  if (field.type() == FieldDescriptor::TYPE_BYTES) return {FieldKind::kBytes, 1024};
  const std::string& name = field.name();
  if (EndsWith(name, "sha256_hex")) return {FieldKind::kHex, kMaxHexBytes};
  if (EndsWith(name, "page_token")) return {FieldKind::kName, kMaxPageTokenBytes};
  static const std::set<std::string, std::less<>> kNames = {
      "title", "display_name", "label", "file_label", "actor_label", "curriculum_title", "target"};
  if (kNames.count(name)) return {FieldKind::kName, kMaxNameBytes};
  static const std::set<std::string, std::less<>> kDescriptions = {"description", "notes"};
  if (kDescriptions.count(name)) return {FieldKind::kText, kMaxDescriptionBytes};
  static const std::set<std::string, std::less<>> kTexts = {"detail", "checks", "note", "result",
                                                            "source"};
  if (kTexts.count(name)) return {FieldKind::kText, kMaxTextBytes};
  return {FieldKind::kId, kMaxIdBytes};
}

int LimitItemsOf(const FieldDescriptor& field) {
  const auto named = NamedItemLimits().find(field.full_name());
  return named != NamedItemLimits().end() ? named->second : kMaxRepeatedItems;
}

bool IsValidUtf8(std::string_view text) {
  for (std::size_t i = 0; i < text.size();) {
    std::uint32_t cp = 0;
    const std::size_t n = Utf8SequenceAt(text, i, &cp);
    if (n == 0) return false;
    i += n;
  }
  return true;
}

bool IsPrintableText(std::string_view text, bool allow_newlines) {
  return CheckText(text, {allow_newlines ? FieldKind::kText : FieldKind::kName, text.size()})
      .empty();
}

bool IsPrintableId(std::string_view id) {
  return !id.empty() && CheckText(id, {FieldKind::kId, kMaxIdBytes}).empty();
}

std::string PrintableExcerpt(std::string_view text, std::size_t max_bytes) {
  std::string out;
  std::size_t i = 0;
  while (i < text.size() && i < max_bytes) {
    std::uint32_t cp = 0;
    std::size_t n = Utf8SequenceAt(text, i, &cp);
    if (n == 0 || IsControl(cp)) {
      char escaped[8];
      std::snprintf(escaped, sizeof escaped, "\\x%02x", static_cast<unsigned char>(text[i]));
      out += escaped;
      n = 1;
    } else if (i + n > max_bytes) {
      break;
    } else {
      out.append(text.substr(i, n));
    }
    i += n;
  }
  if (i < text.size()) out += "…(" + std::to_string(text.size()) + " bytes)";
  return out;
}

LimitProblem FindLimitProblem(const Message& message, const std::string& path, bool* found) {
  LimitProblem problem;
  *found = CheckFields(message, path, 0, &problem);
  return problem;
}

std::string CheckMessageLimits(const Message& message, const std::string& path) {
  bool found = false;
  const LimitProblem p = FindLimitProblem(message, path, &found);
  if (!found) return {};
  if (!p.is_text) return p.path + ": " + p.why;
  return p.path + " = '" + p.excerpt + "': " + p.why;
}

}  // namespace ves::patient_db
