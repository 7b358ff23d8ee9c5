#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <memory>
#include <mutex>
#include <string>
#include <thread>

#include "station/sync/server_client.h"
#include "ves/v1/live.pb.h"

// Live proctoring, the station's side (docs/station-run.md, docs/web.md):
// frames of the running session go to Live.StreamSession from a thread of
// their own through a small bounded queue. Offer() never blocks (a contended
// lock or a full queue drops the frame, counted); a slow or absent network
// only loses frames. When the stream breaks the thread reconnects a few
// times, then gives up quietly; a refusal by the server (bad token, unknown
// trainee, bad frame) is not retried.
namespace ves::sync {

inline constexpr std::size_t kLiveQueueFrames = 4;
// The server's bound on LiveFrame.endoscope_jpeg (server/live_hub.h).
inline constexpr std::size_t kMaxLiveJpegBytes = 64 << 10;

struct LiveStreamStats {
  uint64_t offered = 0;
  uint64_t sent = 0;
  uint64_t dropped = 0;  // queue full or lock contended, or no stream at the time
  int connects = 0;
  bool gave_up = false;
  std::string last_error;  // why the stream ended, "" when it ended well
};

class LiveStreamer {
 public:
  // `first` names the session (uuid, trainee, case): it is sent first on
  // every (re)connection. CheckEndpoint's rules apply (no token in clear
  // off loopback): throws std::invalid_argument.
  LiveStreamer(ServerEndpoint endpoint, ves::v1::LiveFrame first);
  ~LiveStreamer();
  // Queues a frame for sending; never blocks, never throws.
  void Offer(ves::v1::LiveFrame frame);
  // True while a stream is open and nothing waits in the queue (a good
  // moment for an expensive frame); never blocks (false when busy).
  bool Idle();
  // Ends the stream (WritesDone, Finish), waiting at most `wait_ms` before
  // cancelling it, and joins the thread.
  LiveStreamStats Close(int wait_ms = 2000);
  // Hands the end of the stream to the streamer's own thread and returns at
  // once (interactive runs: a session ends while the windows keep drawing).
  // Offers after it drop. Poll with Reap; Close still works afterwards.
  void RequestClose(int wait_ms = 2000);
  // After RequestClose, never blocks: true (and `*stats` set) once the thread
  // has ended and been joined; a stream still open `wait_ms` after the
  // request is cancelled here.
  bool Reap(LiveStreamStats* stats);

 private:
  void Run();
  bool Stream();  // one connection; false: give up for good

  ServerEndpoint endpoint_;
  ves::v1::LiveFrame first_;
  std::mutex mutex_;
  std::condition_variable cv_;
  std::deque<ves::v1::LiveFrame> queue_;    // guarded by mutex_
  bool closing_ = false;                    // guarded by mutex_
  bool connected_ = false;                  // guarded by mutex_
  grpc::ClientContext* context_ = nullptr;  // the live call's, guarded by mutex_
  LiveStreamStats stats_;                   // guarded by mutex_
  std::atomic<uint64_t> dropped_{0};
  std::atomic<bool> finished_{false};  // Run() returned
  std::chrono::steady_clock::time_point cancel_at_{};  // guarded by mutex_
  std::thread thread_;
};

}  // namespace ves::sync
