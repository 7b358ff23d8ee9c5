#pragma once

#include <cstddef>
#include <cstdint>
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
//    "frames","frame":BASE64,"image":N}
//   {"v":1,"kind":"image","replica":ID,"session":UUID,"image":N,"part":I,
//    "parts":P,"data":BASE64}
// `frame` is the LiveFrame as protobuf (ids cleared: the envelope has them),
// base64: half the size of the same numbers as JSON text, and the receiver
// checks it with the gRPC path's own CheckLiveFrame. Its JPEG (10-20 KiB,
// too big for one notification) follows in `image` notices, P parts of it;
// the frame's `image` names that image, which completes the frame.
namespace ves::server {

// PostgreSQL refuses a NOTIFY payload of 8000 bytes or more.
inline constexpr size_t kMaxLiveNoticeBytes = 7999;
inline constexpr size_t kMaxReplicaIdBytes = 64;

// An image part carries at most this many JPEG bytes: 6912 base64
// characters, so the notice stays under 7300 bytes with every id at its bound.
inline constexpr size_t kLiveImagePartBytes = 5184;
// A JPEG of kMaxLiveJpegBytes (the gRPC path's bound) makes 13 parts.
inline constexpr int kMaxLiveImageParts = 16;

enum class LiveNoticeKind { kBegin, kFrame, kEnd, kImage };

// One part of an image: kImage notices.
struct LiveImagePart {
  int part = 0;       // 0..parts-1
  int parts = 0;      // 1..kMaxLiveImageParts
  std::string bytes;  // this part's JPEG bytes (1..kLiveImagePartBytes when sent)
};

struct LiveNotice {
  LiveNoticeKind kind = LiveNoticeKind::kFrame;
  std::string replica_id;  // the sender; a replica ignores its own
  LiveSessionInfo info;    // session_uuid always; the rest on begin and frame
  v1::LiveFrame frame;     // kFrame only
  // kFrame: the image that completes this frame (0: none); kImage: the
  // image this part belongs to. Numbered per session from 1.
  uint64_t image = 0;
  LiveImagePart part;  // kImage only
};

// The payload; "" when it would be more than kMaxLiveNoticeBytes. A frame's
// JPEG never rides in it (it goes in image notices: SplitLiveImage).
std::string EncodeLiveNotice(const LiveNotice& notice);

// How many parts of kLiveImagePartBytes a JPEG of `jpeg_bytes` makes; 0 when
// it cannot go (empty, or more than kMaxLiveImageParts).
int LiveImagePartCount(size_t jpeg_bytes);

// A payload from the channel, which anyone who can connect to the database
// can write to: size bounded, parsed without exceptions, every field checked
// (ids printable, numbers in range, the frame through CheckLiveFrame).
// nullopt with `why` naming the first problem.
std::optional<LiveNotice> ParseLiveNotice(std::string_view payload, std::string* why);

}  // namespace ves::server
