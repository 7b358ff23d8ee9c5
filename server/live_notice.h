#pragma once

#include <cstddef>
#include <optional>
#include <string>
#include <string_view>

#include "server/live_hub.h"
#include "ves/v1/live.pb.h"

// What one replica tells the others about a live session it holds, as a
// PostgreSQL NOTIFY payload (docs/web.md, "Live proctoring across replicas").
// Pure: no I/O. The payload is one JSON object:
//   {"v":1,"kind":"begin"|"frame"|"end","replica":ID,"session":UUID,
//    "institution","trainee","case","case_version","station","started_unix_ms",
//    "frames","frame":BASE64}
// `frame` is the LiveFrame as protobuf (ids cleared: the envelope has them),
// base64: half the size of the same numbers as JSON text, and the receiver
// checks it with the gRPC path's own CheckLiveFrame. Its JPEG rides along only
// when the whole payload still fits.
namespace ves::server {

// PostgreSQL refuses a NOTIFY payload of 8000 bytes or more.
inline constexpr size_t kMaxLiveNoticeBytes = 7999;
inline constexpr size_t kMaxReplicaIdBytes = 64;

enum class LiveNoticeKind { kBegin, kFrame, kEnd };

struct LiveNotice {
  LiveNoticeKind kind = LiveNoticeKind::kFrame;
  std::string replica_id;  // the sender; a replica ignores its own
  LiveSessionInfo info;    // session_uuid always; the rest on begin and frame
  v1::LiveFrame frame;     // kFrame only
};

// The payload, with the frame's JPEG when it fits; "" when even without it
// the notice would be kMaxLiveNoticeBytes or more. `jpeg_dropped` says
// whether a JPEG was left out.
std::string EncodeLiveNotice(const LiveNotice& notice, bool* jpeg_dropped = nullptr);

// A payload from the channel, which anyone who can connect to the database
// can write to: size bounded, parsed without exceptions, every field checked
// (ids printable, numbers in range, the frame through CheckLiveFrame).
// nullopt with `why` naming the first problem.
std::optional<LiveNotice> ParseLiveNotice(std::string_view payload, std::string* why);

}  // namespace ves::server
