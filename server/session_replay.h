#pragma once

#include <atomic>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

#include "station/training/replay.h"
#include "ves/v1/session.pb.h"

// What the web pages show of a stored session (docs/web.md): time series and
// a replay of scope and colon shapes, recomputed by re-running the model from
// the record's input log (training::ReplayRecord, the judge's replay).
namespace ves::server {

struct ReplayFrame {
  double t_s = 0;
  double base_force_N = 0;  // thrust at the base: what the hand feels
  double stretch_m = 0;     // largest mesentery stretch
  double tip_arc_m = 0;     // tip depth along the colon
  double inserted_m = 0;
  bool pain = false;  // stretch over the pain threshold
  bool loop = false;  // loop index over its enter threshold (until under its exit one)
  // AP fluoroscopy projection (image right = -x, up = +z of W), millimetres;
  // empty on frames between shape samples (the first and last frames have them).
  std::vector<std::pair<int, int>> scope_mm;
  std::vector<std::pair<int, int>> colon_mm;
};

struct SessionReplay {
  std::vector<ReplayFrame> frames;  // every 1/series_hz seconds, the first and the last step
  double pain_stretch_m = 0;
  double cecum_arc_m = 0;
  double final_tip_arc_m = 0;  // after the last logged step
  std::string summary_line;    // training::SummaryLine of the replay
};

// Throws std::runtime_error (training::ReplayError, InputLogError, ...) when
// the record cannot be replayed, or ReplayCancelled once `cancel` is true.
// `series_hz` in 0.01..100; shapes at most `shape_hz`, at most `max_points`
// per polyline.
struct ReplayCancelled : std::runtime_error {
  using std::runtime_error::runtime_error;
};
SessionReplay ReplaySession(const v1::SessionRecord& record, double series_hz = 10.0,
                            double shape_hz = 5.0, int max_points = 80,
                            const std::atomic<bool>* cancel = nullptr);

// What ReplaySession keeps of each step, for a replay run by someone else:
// the lesson judge's replay records a lesson session's series as it judges
// (docs/web.md, "Session series"), so that session is replayed once. Pass
// OnStep to the replay's step callback, then Finish with its result.
class ReplayRecorder {
 public:
  // `log`: the replayed input log (its step and sample count set the rates).
  ReplayRecorder(const v1::InputLog& log, double series_hz, double shape_hz, int max_points,
                 const std::atomic<bool>* cancel = nullptr);
  // Throws ReplayCancelled once `cancel` is true.
  void OnStep(const training::SessionRunner& runner);
  SessionReplay Finish(const training::RunResult& result);

 private:
  int64_t n_steps_;
  int64_t series_every_;
  int64_t shape_every_;
  int max_points_;
  const std::atomic<bool>* cancel_;
  int64_t step_ = 0;
  SessionReplay out_;
};

}  // namespace ves::server
