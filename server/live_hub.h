#pragma once

#include <condition_variable>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "patient_db/limits.h"
#include "ves/v1/live.pb.h"

// Live proctoring on the server (docs/web.md, "Live proctoring"): stations
// stream LiveFrames (Live.StreamSession); the hub keeps each running
// session's newest frame and hands it to that session's viewers (WebSocket
// connections of supervisors). Each viewer has a one-slot buffer: a slow
// viewer only ever gets the newest frame, and publishing never waits for one.
// With several replicas on PostgreSQL the hub also holds the sessions other
// replicas stream (remote, from a LiveRelay's notices) and hands its own to
// the relay; viewers and lists treat both alike.
namespace ves::server {

// Bounds on a LiveFrame (docs/web.md, "Live proctoring" and "Limits").
inline constexpr int kMaxLivePolylinePoints = 200;  // per polyline (x,y,z each)
inline constexpr size_t kMaxLiveJpegBytes = patient_db::kMaxLiveJpegBytes;
inline constexpr int kMaxLiveSessions = 1000;  // streams at once on one server
inline constexpr int kMaxLiveViewersPerSession = 32;

// INVALID_ARGUMENT-style message naming the first bad field ("" when fine).
// `first` frames must name session_uuid, trainee_id and case_id.
std::string CheckLiveFrame(const v1::LiveFrame& frame, bool first);
// The frame's JPEG part of CheckLiveFrame: size and FF D8 FF signature.
std::string CheckLiveJpeg(const std::string& jpeg);

// The frame as the live page's JSON (scope_mm / colon_mm in the AP
// projection the replay uses; the JPEG as base64).
std::string LiveFrameJson(const v1::LiveFrame& frame, int64_t received_unix_ms);

// Standard base64 with padding, no line breaks (the JPEG in a viewer's frame,
// the protobuf and image parts in a replica notice).
std::string EncodeBase64(const std::string& bytes);

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
  std::string origin_replica;  // "" when streamed to this replica, else the one that holds it
};

struct LiveNotice;

// Milliseconds on the steady clock: remote sessions' silence and the relay's
// throttling and backoff are measured on it.
int64_t SteadyNowMs();

// Where a hub sends its own sessions for other replicas to see. Called on
// the stream's thread: must not block (LivePgRelay queues).
class LiveRelay {
 public:
  virtual ~LiveRelay() = default;
  virtual void Began(const LiveSessionInfo& info) = 0;
  virtual void Framed(const LiveSessionInfo& info, const v1::LiveFrame& frame) = 0;
  virtual void Ended(const std::string& session_uuid) = 0;
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
  // Set before serving; nullptr: none (SQLite, one process).
  void SetRelay(LiveRelay* relay) { relay_ = relay; }

  // False (with `why`) when kMaxLiveSessions stream already or the uuid is
  // streaming from another stream here. A session another replica held
  // (its station reconnected here) becomes this replica's, viewers kept.
  bool Begin(const LiveSessionInfo& info, std::string* why);
  void Publish(const std::string& session_uuid, const v1::LiveFrame& frame);
  void End(const std::string& session_uuid);

  // A checked notice from another replica (ParseLiveNotice): a begin or
  // frame starts the remote session when it is new (at most kMaxLiveSessions
  // remote ones), a frame reaches its viewers, an end ends it. Notices about
  // a session streaming here are ignored. False when refused (over the bound).
  bool ApplyRemote(const LiveNotice& notice);
  // Ends remote sessions that had no notice for `silence_ms` (their replica
  // died or lost its database connection); how many.
  int ExpireRemote(int64_t silence_ms);

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
    int64_t last_notice_steady_ms = 0;  // remote sessions: for ExpireRemote
  };
  // The frame to the session's viewers; false when it is not live here.
  bool Deliver(const std::string& session_uuid, const v1::LiveFrame& frame, bool remote,
               LiveSessionInfo* info);
  static void EndViewers(const std::vector<std::shared_ptr<LiveViewer>>& viewers);

  LiveRelay* relay_ = nullptr;
  mutable std::mutex mutex_;
  std::map<std::string, Live> live_;  // by session uuid
  int local_ = 0;                     // sessions streaming here (the rest are remote)
};

}  // namespace ves::server
