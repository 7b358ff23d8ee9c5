#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <iosfwd>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "station/sync/live_stream.h"
#include "station/training/session_runner.h"

// What `ves-station run` streams for live proctoring (docs/station-run.md):
// every 1/20 s of session time a LiveFrame (scope and colon shape decimated
// to 80 points, tip pose, hand force, inserted length, tip depth, stretch,
// pain and loop flags) goes to a LiveStreamer, which never blocks the loop.
namespace ves::station {

inline constexpr double kLiveFramePeriodS = 0.05;  // 20 Hz
inline constexpr int kLivePolylinePoints = 80;
inline constexpr double kLiveJpegPeriodS = 0.2;  // 5 Hz, wall clock

// The figures of a frame besides the shapes: plain values, so the haptic
// loop can hand them to the UI thread without allocating.
struct LiveFigures {
  double t_s{0.0};
  double base_force_N{0.0};
  double inserted_m{0.0};
  double tip_arc_m{0.0};
  double stretch_m{0.0};
  bool pain{false};
  bool loop{false};
};
LiveFigures LiveFiguresOf(const training::SessionRunner& runner);

// The frame of a model state (no session ids).
ves::v1::LiveFrame MakeLiveFrame(const model::ModelState& state, const LiveFigures& figures);
// The frame of the runner's current step (no session ids).
ves::v1::LiveFrame MakeLiveFrame(const training::SessionRunner& runner);

// An endoscope image as the small JPEG of a live frame (320 pixels wide,
// quality 70); "" for an empty image or a failed encoding.
std::string EncodeLiveJpeg(const cv::Mat& image);

class LivePublisher {
 public:
  // Streams only with a server; a refusal of the endpoint (CheckEndpoint)
  // has been reported when the options were parsed.
  LivePublisher(const std::optional<sync::ServerEndpoint>& server, const std::string& session_uuid,
                const std::string& trainee_id, const std::string& case_id, uint32_t case_version);
  // After each model step; builds and offers a frame every kLiveFramePeriodS
  // of session time. `jpeg` (may be empty) renders the endoscope image: it is
  // called at most every kLiveJpegPeriodS of wall-clock time, and only while
  // the stream is open and its queue empty, so rendering costs a headless
  // run at most 5 renders per second and nothing when the network is slow.
  void OnStep(const training::SessionRunner& runner, const std::function<std::string()>& jpeg = {});
  // The same for a state taken elsewhere (the UI thread of an interactive
  // run): `make` builds the frame only when one is due at session time `t_s`.
  void OnState(double t_s, const std::function<ves::v1::LiveFrame()>& make,
               const std::function<std::string()>& jpeg = {});
  // Ends the stream; one line on `log` (frames sent, dropped, why it stopped).
  void Finish(std::ostream& log);
  // Never blocks: the end of the stream goes to the streamer's own thread;
  // poll Reap until it says the stream is over (then `*stats` is set).
  void EndInBackground();
  bool Reap(sync::LiveStreamStats* stats);
  bool streaming() const { return streamer_ != nullptr; }

 private:
  std::unique_ptr<sync::LiveStreamer> streamer_;
  double next_frame_s_ = 0.0;
  std::chrono::steady_clock::time_point next_jpeg_{};
};

// Interactive runs (run_interactive.cc): one stream per session, fed by
// the UI thread with the haptic loop's publications. A session that ends or
// is repeated has its stream ended in the background, so a dead or slow
// server never holds up the windows (nor the loop, which never sees it).
class InteractiveLive {
 public:
  // Streams only with a server (nullopt: --no-live or no --server).
  InteractiveLive(std::optional<sync::ServerEndpoint> server, std::string trainee_id,
                  std::string case_id, uint32_t case_version);
  ~InteractiveLive();
  // UI thread, for each new publication: `session_uuid` names its session,
  // `running` whether it still runs. A new uuid ends the previous stream and
  // opens one for it; a session over ends its stream after its last frame.
  // Never blocks.
  void OnPublication(const std::string& session_uuid, bool running, double t_s,
                     const std::function<ves::v1::LiveFrame()>& make,
                     const std::function<std::string()>& jpeg = {});
  // UI thread, each frame without a publication: reaps ended streams and
  // cancels one still open 2 s after its end was asked. Never blocks.
  void Poll() { ReapEnded(); }
  // At the end of the run: ends every stream (waiting at most 2 s for each
  // still open) and writes one line on `log` (sessions, frames, drops).
  void Finish(std::ostream& log);

 private:
  void ReapEnded();
  void Count(const sync::LiveStreamStats& s);

  std::optional<sync::ServerEndpoint> server_;
  std::string trainee_id_;
  std::string case_id_;
  uint32_t case_version_;
  std::string current_uuid_;
  bool current_streamed_{false};  // current_uuid_'s stream was opened (it may have ended)
  std::unique_ptr<LivePublisher> current_;
  std::vector<std::unique_ptr<LivePublisher>> ending_;
  int sessions_{0};
  uint64_t sent_{0};
  uint64_t dropped_{0};
  std::string last_error_;
};

}  // namespace ves::station
