#pragma once

#include <condition_variable>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "ves/v1/live.pb.h"

// Live proctoring on the server (docs/web.md, "Live proctoring"): stations
// stream LiveFrames (Live.StreamSession); the hub keeps each running
// session's newest frame and hands it to that session's viewers (WebSocket
// connections of supervisors). Each viewer has a one-slot buffer: a slow
// viewer only ever gets the newest frame, and publishing never waits for one.
namespace ves::server {

// Bounds on a LiveFrame (docs/web.md, "Live proctoring" and "Limits").
inline constexpr int kMaxLivePolylinePoints = 200;  // per polyline (x,y,z each)
inline constexpr size_t kMaxLiveJpegBytes = 64 << 10;
inline constexpr int kMaxLiveSessions = 1000;  // streams at once on one server
inline constexpr int kMaxLiveViewersPerSession = 32;

// INVALID_ARGUMENT-style message naming the first bad field ("" when fine).
// `first` frames must name session_uuid, trainee_id and case_id.
std::string CheckLiveFrame(const v1::LiveFrame& frame, bool first);

// The frame as the live page's JSON (scope_mm / colon_mm in the AP
// projection the replay uses; the JPEG as base64).
std::string LiveFrameJson(const v1::LiveFrame& frame, int64_t received_unix_ms);

struct LiveSessionInfo {
  std::string session_uuid;
  std::string institution;  // the trainee's
  std::string trainee_id;
  std::string case_id;
  uint32_t case_version = 0;
  std::string station;  // the streaming token's label
  int64_t started_unix_ms = 0;
  int64_t last_frame_unix_ms = 0;
  uint64_t frames = 0;
  uint64_t station_dropped = 0;
  double t_s = 0;
};

// One viewer's one-slot buffer.
class LiveViewer {
 public:
  // The next frame's JSON, waiting up to `wait_ms`; "" on timeout. `ended`
  // is set once the stream is over and the last frame was taken.
  std::string Next(int wait_ms, bool* ended);
  uint64_t overwritten() const;  // frames replaced before this viewer took them

 private:
  friend class LiveHub;
  mutable std::mutex mutex_;
  std::condition_variable cv_;
  std::shared_ptr<const std::string> slot_;
  bool ended_ = false;
  uint64_t overwritten_ = 0;
};

class LiveHub {
 public:
  // False (with `why`) when kMaxLiveSessions stream already or the uuid is
  // streaming from another stream.
  bool Begin(const LiveSessionInfo& info, std::string* why);
  void Publish(const std::string& session_uuid, const v1::LiveFrame& frame);
  void End(const std::string& session_uuid);

  // Live sessions, all of them (institution "") or one institution's.
  std::vector<LiveSessionInfo> List(const std::string& institution) const;
  bool Find(const std::string& session_uuid, LiveSessionInfo* info) const;

  // A viewer of a live session (with the newest frame already in its slot);
  // nullptr when the session is not live or has too many viewers.
  std::shared_ptr<LiveViewer> Watch(const std::string& session_uuid, std::string* why);
  void Unwatch(const std::string& session_uuid, const std::shared_ptr<LiveViewer>& viewer);

 private:
  struct Live {
    LiveSessionInfo info;
    std::shared_ptr<const std::string> latest;
    std::vector<std::shared_ptr<LiveViewer>> viewers;
  };
  mutable std::mutex mutex_;
  std::map<std::string, Live> live_;  // by session uuid
};

}  // namespace ves::server
