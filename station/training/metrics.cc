#include "station/training/metrics.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace ves::training {

double LoopIndex::Update(double inserted_m, double tip_arc_m) {
  const double slack_m = inserted_m - tip_arc_m;
  const double depth_m = std::isfinite(tip_arc_m) ? std::max(0.0, tip_arc_m) : 0.0;
  const std::size_t bin = std::min(static_cast<std::size_t>(depth_m / kDepthBin_m), kMaxBins - 1);
  if (bin >= min_slack_up_to_bin_.size()) {
    // A new depth: its reference starts at the lowest slack of all shallower ones.
    const double shallower = min_slack_up_to_bin_.empty() ? std::numeric_limits<double>::infinity()
                                                          : min_slack_up_to_bin_.back();
    min_slack_up_to_bin_.resize(bin + 1, shallower);
  }
  // This slack lowers the reference of this depth and of every deeper one.
  for (std::size_t b = bin; b < min_slack_up_to_bin_.size() && slack_m < min_slack_up_to_bin_[b];
       ++b) {
    min_slack_up_to_bin_[b] = slack_m;
  }
  value_ = slack_m - min_slack_up_to_bin_[bin];
  return value_;
}

double MetricsAccumulator::WindowMean::Add(double value, int window_steps) {
  if (count_ == window_steps) {
    sum_ -= values_[next_];
  } else {
    ++count_;
  }
  values_[next_] = value;
  sum_ += value;
  next_ = (next_ + 1) % window_steps;
  return sum_ / count_;
}

MetricsAccumulator::MetricsAccumulator(const MetricThresholds& thresholds)
    : thresholds_(thresholds),
      force_(thresholds.episode_merge_gap_s),
      pain_(thresholds.episode_merge_gap_s),
      loop_(0.0),  // the loop's hysteresis already debounces it
      redout_(thresholds.episode_merge_gap_s),
      damage_(thresholds.episode_merge_gap_s) {}

void MetricsAccumulator::Add(const StepObservation& o) {
  const MetricThresholds& th = thresholds_;
  const double dt = o.dt_s;
  t_s_ = o.t_s;
  running_s_ += dt;

  const double force_N = std::abs(o.base_force_N);
  const int window_steps =
      std::clamp(static_cast<int>(std::lround(kForceWindow_s / dt)), 1, kForceWindowMaxSteps);
  peak_force_N_ = std::max(peak_force_N_, hand_force_window_.Add(force_N, window_steps));
  force_integral_N_s_ += force_N * dt;

  const bool force_over = o.max_wall_force_N > th.excessive_wall_force_N;
  force_.Update(o.t_s, dt, force_over, o.max_wall_force_N, o.max_wall_force_arc_m,
                o.max_wall_force_N - th.excessive_wall_force_N);
  // Damage: the largest wall force held over the perforation load for the
  // force window, not a transient of a step or three (docs/scoring.md).
  const double wall_mean_N = wall_force_window_.Add(o.max_wall_force_N, window_steps);
  damage_.Update(o.t_s, dt, wall_mean_N > th.damage_wall_force_N, wall_mean_N,
                 o.max_wall_force_arc_m, wall_mean_N - th.damage_wall_force_N);
  // The map shows where the wall was pressed during damage episodes.
  if (!o.segment_wall_force_N.empty()) {
    if (damage_map_N_s_.size() != o.segment_wall_force_N.size()) {
      damage_map_N_s_.assign(o.segment_wall_force_N.size(), 0.0);
    }
    for (std::size_t i = 0; i < o.segment_wall_force_N.size(); ++i) {
      const double excess_N = o.segment_wall_force_N[i] - th.damage_wall_force_N;
      if (excess_N > 0.0 && wall_mean_N > th.damage_wall_force_N) {
        damage_map_N_s_[i] += excess_N * dt;
      }
    }
  }

  peak_stretch_m_ = std::max(peak_stretch_m_, o.peak_stretch_m);
  pain_.Update(o.t_s, dt, o.peak_stretch_m > th.pain_stretch_m, o.peak_stretch_m,
               o.peak_stretch_arc_m, o.peak_stretch_m - th.pain_stretch_m);

  // Loop with hysteresis: enters at loop_enter_m, leaves below loop_exit_m.
  const double index_m = loop_index_.Update(o.inserted_m, o.tip_arc_m);
  if (!in_loop_ && index_m >= th.loop_enter_m) in_loop_ = true;
  if (in_loop_ && index_m < th.loop_exit_m) in_loop_ = false;
  loop_.Update(o.t_s, dt, in_loop_, index_m, o.tip_arc_m, index_m - th.loop_enter_m);

  redout_.Update(o.t_s, dt, o.redout_fraction >= th.redout_fraction, o.redout_fraction, o.tip_arc_m,
                 0.0);
  mucosa_seen_ = std::max(mucosa_seen_, o.mucosa_seen_fraction);
  if (o.fluoroscopy_on) xray_s_ += dt;
  if (o.abdominal_press == AbdominalPress::kLeftLowerQuadrant) press_llq_s_ += dt;
  if (o.abdominal_press == AbdominalPress::kMidAbdomen) press_mid_s_ += dt;
  if (o.patient_position == PatientPosition::kLeftLateral) left_lateral_s_ += dt;
  if (o.patient_position == PatientPosition::kRightLateral) right_lateral_s_ += dt;
  if (o.patient_position != position_) {
    ++position_changes_;
    position_ = o.patient_position;
  }

  if (steps_ > 0) tip_path_m_ += (o.p_WTip - last_tip_).norm();
  last_tip_ = o.p_WTip;
  max_inserted_m_ = std::max(max_inserted_m_, o.inserted_m);
  max_tip_arc_m_ = std::max(max_tip_arc_m_, o.tip_arc_m);

  if (!cecum_time_s_ && o.tip_arc_m >= th.cecum_arc_m) {
    cecum_time_s_ = o.t_s;
    cecum_inserted_m_ = o.inserted_m;
    toggles_.push_back({.t_s = o.t_s,
                        .kind = EventKind::kCecumReached,
                        .arc_m = o.tip_arc_m,
                        .detail = "tip arc m"});
  }
  if (view_mode_ != o.view_mode) {
    if (view_mode_) {
      toggles_.push_back({.t_s = o.t_s,
                          .kind = EventKind::kViewMode,
                          .value = static_cast<double>(o.view_mode),
                          .detail = "0 wireframe, 1 flat, 2 textured"});
    }
    view_mode_ = o.view_mode;
  }
  if (fluoroscopy_on_ != o.fluoroscopy_on) {
    if (fluoroscopy_on_ || o.fluoroscopy_on) {
      toggles_.push_back({.t_s = o.t_s,
                          .kind = EventKind::kFluoroscopy,
                          .value = o.fluoroscopy_on ? 1.0 : 0.0,
                          .detail = o.fluoroscopy_on ? "on" : "off"});
    }
    fluoroscopy_on_ = o.fluoroscopy_on;
  }
  ++steps_;
}

Metrics MetricsAccumulator::Result() const {
  EpisodeTracker force = force_;
  EpisodeTracker loop = loop_;
  EpisodeTracker damage = damage_;
  force.Finish();
  loop.Finish();
  damage.Finish();
  Metrics m;
  m.duration_s = t_s_;
  m.completed = cecum_time_s_.has_value();
  m.time_to_cecum_s = cecum_time_s_.value_or(0.0);
  m.inserted_at_cecum_m = cecum_time_s_ ? cecum_inserted_m_ : 0.0;
  m.peak_insertion_force_N = peak_force_N_;
  m.mean_insertion_force_N = running_s_ > 0.0 ? force_integral_N_s_ / running_s_ : 0.0;
  m.excessive_force_episodes = static_cast<std::uint32_t>(force.episodes().size());
  m.excessive_force_s = force.total_s();
  m.pain_s = pain_.total_s();
  m.peak_stretch_m = peak_stretch_m_;
  m.loop_s = loop.total_s();
  m.loop_count = static_cast<std::uint32_t>(loop.episodes().size());
  m.redout_s = redout_.total_s();
  m.mucosa_seen_fraction = mucosa_seen_;
  m.xray_s = xray_s_;
  m.tip_path_m = tip_path_m_;
  m.max_insertion_m = max_inserted_m_;
  m.max_tip_arc_m = max_tip_arc_m_;
  m.damage_events = static_cast<std::uint32_t>(damage.episodes().size());
  for (const Episode& e : damage.episodes()) m.damage_impulse_N_s += e.excess_integral;
  m.press_llq_s = press_llq_s_;
  m.press_mid_s = press_mid_s_;
  m.left_lateral_s = left_lateral_s_;
  m.right_lateral_s = right_lateral_s_;
  m.position_changes = position_changes_;
  return m;
}

std::vector<Event> MetricsAccumulator::Events() const {
  std::vector<Event> events = toggles_;
  auto add = [&events](EpisodeTracker tracker, EventKind kind, const char* detail) {
    tracker.Finish();
    for (const Episode& e : tracker.episodes()) {
      events.push_back({.t_s = e.start_s,
                        .kind = kind,
                        .duration_s = e.duration_s,
                        .arc_m = e.peak_arc_m,
                        .value = kind == EventKind::kDamage ? e.excess_integral : e.peak_value,
                        .detail = detail});
    }
  };
  add(force_, EventKind::kExcessiveForce, "peak wall force N");
  add(pain_, EventKind::kPain, "peak mesentery stretch m");
  add(loop_, EventKind::kLoop, "peak loop index m");
  add(damage_, EventKind::kDamage, "wall force impulse over damage threshold N*s");
  add(redout_, EventKind::kRedout, "peak red-out fraction");
  std::stable_sort(events.begin(), events.end(),
                   [](const Event& a, const Event& b) { return a.t_s < b.t_s; });
  return events;
}

}  // namespace ves::training
