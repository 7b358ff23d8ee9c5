#pragma once

#include <google/protobuf/descriptor.h>
#include <google/protobuf/message.h>

#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

// Limits at every edge (docs/server.md, "Limits"): how long every string and
// bytes field of a ves.v1 message may be, which characters it may hold and how
// many items every repeated field may have. Written once here, by field kind
// and a few named fields; the gRPC handlers check every request with
// CheckMessageLimits before anything is authorised, stored or decoded, and
// any other front end (HTTP) is to call the same. The station checks its own
// command-line ids with IsPrintableId. Pure: no I/O.
namespace ves::patient_db {

// What a string or bytes field holds, by its name (LimitOf).
enum class FieldKind {
  kId,     // ids and names of things: printable UTF-8, no control characters
  kHex,    // SHA-256 hex: lower-case hex digits
  kName,   // titles, display names, labels: printable UTF-8
  kText,   // descriptions, notes, check lines: printable UTF-8, newlines and tabs too
  kBytes,  // opaque bytes (case bundles, input logs, images)
};

struct FieldLimit {
  FieldKind kind = FieldKind::kName;
  std::size_t max_bytes = 0;
};

inline constexpr std::size_t kMaxIdBytes = 128;
inline constexpr std::size_t kMaxHexBytes = 64;
inline constexpr std::size_t kMaxNameBytes = 256;
inline constexpr std::size_t kMaxTextBytes = 4096;
inline constexpr std::size_t kMaxDescriptionBytes = 16384;
inline constexpr std::size_t kMaxInputLogBytes = std::size_t{12} << 20;  // below the 16 MiB message
inline constexpr std::size_t kMaxTextureBytes = std::size_t{64} << 20;
inline constexpr std::size_t kMaxChunkBytes = std::size_t{1} << 20;  // case bundle chunks
inline constexpr std::size_t kMaxLiveJpegBytes = std::size_t{64} << 10;  // a live frame's image
// Repeated fields: this many items unless LimitItemsOf names another bound.
inline constexpr int kMaxRepeatedItems = 1000;
// Control points and radius samples of a case (also checked by ValidateCase).
inline constexpr int kMaxCasePoints = 5000;
inline constexpr int kMaxCaseRegions = 64;
inline constexpr int kMaxSessionEvents = 100000;
inline constexpr int kMaxCurriculumLessons = 200;
// List replies: page_size 0 means kDefaultPageSize, more than kMaxPageSize is cut to it.
inline constexpr int kDefaultPageSize = 100;
inline constexpr int kMaxPageSize = 1000;
inline constexpr std::size_t kMaxPageTokenBytes = 512;

// The limit of a string or bytes field.
FieldLimit LimitOf(const google::protobuf::FieldDescriptor& field);
// The most items a repeated field may hold.
int LimitItemsOf(const google::protobuf::FieldDescriptor& field);

// Well-formed UTF-8 (no overlong forms, no surrogates, at most U+10FFFF).
bool IsValidUtf8(std::string_view text);
// Valid UTF-8 without control characters (C0, DEL, C1); tab and newline
// allowed only when `allow_newlines`.
bool IsPrintableText(std::string_view text, bool allow_newlines = false);
// An id: 1..kMaxIdBytes bytes of printable UTF-8.
bool IsPrintableId(std::string_view id);

// `text` made safe to show in one line of an error, a log or a terminal: at
// most `max_bytes` of it, control characters and invalid UTF-8 as \xNN,
// "…(N bytes)" when cut.
std::string PrintableExcerpt(std::string_view text, std::size_t max_bytes = 64);

// The first field of a message over its limit.
struct LimitProblem {
  std::string path;     // "record.station_id", "case.centerline"
  std::string excerpt;  // PrintableExcerpt of the value (strings; empty otherwise)
  std::string why;      // "9437184 bytes, more than 128", "control character U+001B"
  bool is_text = false;  // a string or bytes value (else a count or the nesting)
};
LimitProblem FindLimitProblem(const google::protobuf::Message& message, const std::string& path,
                              bool* found);

// Empty when every field of `message` (recursively) is within its limit;
// otherwise one line naming the first field out of bounds, e.g.
// "record.station_id: 9437184 bytes, more than 128" or
// "trainee.display_name = 'A\x1b[31m': control character". `path` names the
// message ("record", "request").
std::string CheckMessageLimits(const google::protobuf::Message& message, const std::string& path);

}  // namespace ves::patient_db
