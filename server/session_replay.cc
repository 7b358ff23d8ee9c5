#include "server/session_replay.h"

#include <cmath>

#include "station/training/case_run.h"
#include "station/training/replay.h"

namespace ves::server {
namespace {

std::pair<int, int> ProjectAp(const Eigen::Vector3d& p_W) {
  return {static_cast<int>(std::lround(-p_W.x() * 1000.0)),
          static_cast<int>(std::lround(p_W.z() * 1000.0))};
}

template <class Points>
std::vector<std::pair<int, int>> Polyline(const Points& points, size_t first, int max_points) {
  std::vector<std::pair<int, int>> out;
  if (first >= points.size()) return out;
  const size_t n = points.size() - first;
  const size_t stride = std::max<size_t>(1, (n + max_points - 1) / max_points);
  for (size_t i = first; i < points.size(); i += stride) out.push_back(ProjectAp(points[i]));
  if ((n - 1) % stride != 0) out.push_back(ProjectAp(points.back()));  // keep the tip / cecum
  return out;
}

}  // namespace

ReplayRecorder::ReplayRecorder(const v1::InputLog& log, double series_hz, double shape_hz,
                               int max_points, const std::atomic<bool>* cancel)
    : n_steps_(static_cast<int64_t>(log.sample_count())),
      series_every_(std::max<int64_t>(1, std::llround(1.0 / (series_hz * log.dt_s())))),
      shape_every_(series_every_ * std::max<int64_t>(1, std::llround(series_hz / shape_hz))),
      max_points_(max_points),
      cancel_(cancel) {}

void ReplayRecorder::OnStep(const training::SessionRunner& runner) {
  ++step_;
  if (cancel_ != nullptr && (step_ & 0xff) == 0 && cancel_->load(std::memory_order_relaxed)) {
    throw ReplayCancelled("replay cancelled");
  }
  const auto& th = runner.session().accumulator().thresholds();
  const auto& obs = runner.observation();
  out_.pain_stretch_m = th.pain_stretch_m;
  out_.cecum_arc_m = th.cecum_arc_m;
  out_.final_tip_arc_m = obs.tip_arc_m;
  // The first step is a frame with shapes too, so the replay opens on the
  // scope at the start rather than on an empty view until the first sample.
  const bool first_or_last = step_ == 1 || step_ == n_steps_;
  if (step_ % series_every_ != 0 && !first_or_last) return;
  ReplayFrame f;
  f.t_s = obs.t_s;
  f.base_force_N = obs.base_force_N;
  f.stretch_m = obs.peak_stretch_m;
  f.tip_arc_m = obs.tip_arc_m;
  f.inserted_m = obs.inserted_m;
  f.pain = obs.peak_stretch_m > th.pain_stretch_m;
  f.loop = runner.session().accumulator().in_loop();
  if (step_ % shape_every_ == 0 || first_or_last) {
    const auto& state = runner.state();
    // The scope from just outside the anus to the tip.
    const size_t first = static_cast<size_t>(std::max(0, state.first_inside_sample - 1));
    f.scope_mm = Polyline(state.p_WSample, first, max_points_);
    f.colon_mm = Polyline(state.p_WColon, 0, max_points_);
  }
  out_.frames.push_back(std::move(f));
}

SessionReplay ReplayRecorder::Finish(const training::RunResult& result) {
  out_.summary_line = training::SummaryLine(result);
  return std::move(out_);
}

SessionReplay ReplaySession(const v1::SessionRecord& record, double series_hz, double shape_hz,
                            int max_points, const std::atomic<bool>* cancel) {
  ReplayRecorder recorder(record.input_log(), series_hz, shape_hz, max_points, cancel);
  const training::RunResult result = training::ReplayRecord(
      record, [&](const training::InputSample&, const training::SessionRunner& runner) {
        recorder.OnStep(runner);
      });
  return recorder.Finish(result);
}

}  // namespace ves::server
