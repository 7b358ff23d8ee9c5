#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <iosfwd>
#include <memory>
#include <optional>
#include <string>

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

// The frame of the runner's current step (no session ids).
ves::v1::LiveFrame MakeLiveFrame(const training::SessionRunner& runner);

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
  // Ends the stream; one line on `log` (frames sent, dropped, why it stopped).
  void Finish(std::ostream& log);

 private:
  std::unique_ptr<sync::LiveStreamer> streamer_;
  double next_frame_s_ = 0.0;
  std::chrono::steady_clock::time_point next_jpeg_{};
};

}  // namespace ves::station
