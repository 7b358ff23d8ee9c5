#pragma once

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <map>
#include <memory>
#include <mutex>
#include <pqxx/connection>
#include <string>
#include <thread>

#include "server/live_hub.h"
#include "server/live_image.h"
#include "server/live_notice.h"

// Live sessions across replicas on one PostgreSQL (docs/web.md, "Live
// proctoring across replicas"): this replica's sessions go out as NOTIFY on
// one channel (EncodeLiveNotice), the other replicas' come in on a LISTEN
// connection and go into the hub as remote sessions (ApplyRemote).
//
// Two threads, each with its own connection (not the store's pool: a LISTEN
// connection is held for good, and a slow database must not stall uploads):
//  - the publisher drains a bounded queue. The stream's thread only queues
//    (never touches the database); a full queue drops the new notice and
//    counts it; frames are thinned to one per min_frame_interval_ms per
//    session. A frame's JPEG follows it as image notices (too big for one),
//    all its parts queued or none. A lost connection drops the notice at
//    hand (and the rest of its image) and reconnects with backoff.
//  - the listener LISTENs, checks every payload (ParseLiveNotice), ignores
//    its own replica's, holds a frame that names an image until the image's
//    parts are in (LiveImageAssembly), ends remote sessions silent for
//    remote_silence_ms (so a killed replica's sessions do not hang), and
//    reconnects with backoff when its connection drops.
namespace ves::server {

struct LivePgRelayOptions {
  std::string url;  // libpq URI of the store's database
  // NOTIFY channels are database-wide, schemas are not: "" takes
  // LiveChannelFor(current_schema()), so deployments in two schemas of one
  // database (and parallel tests) do not see each other's sessions.
  std::string channel;
  int min_frame_interval_ms = 100;  // per session: at most ~10 frames/s leave
  // Per session: at most one JPEG per this long leaves (the station sends
  // one at most every 200 ms; the margin absorbs the network's jitter). A
  // frame with its JPEG is never thinned.
  int min_image_interval_ms = 150;
  size_t queue_capacity = 256;   // notices waiting for the publisher
  int remote_silence_ms = 5000;  // a remote session without a notice this long has ended
  int max_backoff_ms = 10000;    // reconnect backoff: 250 ms doubling up to this
};

// "ves_live" for the schema public, else "ves_live_" and 16 hex digits of
// the schema name's SHA-256 (a channel name is at most 63 bytes; a schema
// name may be 63 already).
std::string LiveChannelFor(const std::string& schema);

class LivePgRelay final : public LiveRelay {
 public:
  // Does not connect; Start does, in the background.
  LivePgRelay(LivePgRelayOptions options, LiveHub* hub);
  ~LivePgRelay() override;
  LivePgRelay(const LivePgRelay&) = delete;
  LivePgRelay& operator=(const LivePgRelay&) = delete;

  void Start();
  // Publishes what is queued for up to `drain` (the ends of streams that
  // shutdown just closed), then stops both threads. Idempotent.
  void Stop(std::chrono::milliseconds drain);

  const std::string& replica_id() const { return replica_id_; }
  // True while the listener's LISTEN is in place.
  bool listening() const;

  void Began(const LiveSessionInfo& info) override;
  void Framed(const LiveSessionInfo& info, const v1::LiveFrame& frame) override;
  void Ended(const std::string& session_uuid) override;

  struct Stats {
    uint64_t published = 0;         // notices sent
    uint64_t throttled = 0;         // frames not sent (another left < min_frame_interval_ms ago)
    uint64_t dropped_full = 0;      // notices dropped: queue full
    uint64_t dropped_oversize = 0;  // notices that did not fit in 8000 bytes
    uint64_t dropped_failed = 0;    // notices lost with a publishing connection
    uint64_t images_published = 0;  // JPEGs sent whole (every part)
    uint64_t images_thinned = 0;    // JPEGs not sent (another left < min_image_interval_ms ago)
    // JPEGs not sent whole: queue full, too big or not ending FF D9, a part
    // lost with the connection (the image's other parts are then not sent).
    uint64_t images_dropped = 0;
    uint64_t received = 0;          // notices from other replicas (image parts too), applied
    uint64_t refused = 0;           // malformed payloads, or over the remote session bound
    uint64_t expired = 0;           // remote sessions ended by silence
    uint64_t images_received = 0;   // frames from other replicas that named an image
    uint64_t images_completed = 0;  // of those, the image came whole and went to viewers
    uint64_t listener_reconnects = 0;
  };
  Stats stats() const;

  // One payload as the listener takes it (tests call it directly).
  void OnNotification(const std::string& payload);

 private:
  struct Outgoing {
    LiveNoticeKind kind = LiveNoticeKind::kFrame;
    LiveSessionInfo info;
    v1::LiveFrame frame;
    uint64_t image = 0;  // kFrame: the image that follows (0: none); kImage: this one
    int part = 0;        // kImage: which part of how many
    int parts = 0;
    std::shared_ptr<const std::string> jpeg;  // kImage: the whole JPEG, shared by its parts
  };
  // Per session on this replica: what the thinning needs.
  struct Outbound {
    int64_t last_frame_ms = 0;  // steady clock
    int64_t last_image_ms = 0;
    bool any_frame = false;
    bool any_image = false;
    uint64_t images = 0;  // the last image's number
  };
  void Enqueue(Outgoing o);
  // The frame and, when it names one, its image's parts: all of them or
  // none (the frame then goes without).
  void EnqueueFrame(Outgoing frame, std::shared_ptr<const std::string> jpeg, int parts);
  void OnImagePart(const LiveNotice& notice);
  void RunPublisher();
  void RunListener();
  // Sleeps up to `ms` (expiring remote sessions meanwhile); false when stopping.
  bool Backoff(int ms);
  void ExpireTick();
  // The channel (options or schema), and application_name
  // "ves live <role> <channel>" set on `conn`.
  std::string Prepare(pqxx::connection_base& conn, const char* role) const;
  void LogRefused(const std::string& why);

  const LivePgRelayOptions options_;
  const std::string url_;  // options_.url with dead-peer timeouts
  LiveHub* const hub_;
  const std::string replica_id_;

  mutable std::mutex mutex_;
  std::condition_variable queue_cv_;          // the publisher waits here (queue, stop)
  std::condition_variable stop_cv_;           // the listener's backoff waits here (stop)
  std::deque<Outgoing> queue_;                // guarded by mutex_
  std::map<std::string, Outbound> outbound_;  // by session uuid; guarded by mutex_
  bool stopping_ = false;                     // guarded by mutex_
  std::chrono::steady_clock::time_point drain_until_;
  bool listening_ = false;           // guarded by mutex_
  Stats stats_;                      // guarded by mutex_
  int64_t last_expire_ms_ = 0;       // listener thread only
  int64_t last_refusal_log_ms_ = 0;  // listener thread only
  uint64_t refusals_unlogged_ = 0;   // listener thread only
  LiveImageAssembly images_;         // listener thread only

  std::thread publisher_;
  std::thread listener_;
  bool started_ = false;
};

}  // namespace ves::server
