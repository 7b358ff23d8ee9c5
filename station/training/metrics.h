#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "station/training/episode_tracker.h"
#include "station/training/metric_thresholds.h"
#include "station/training/observation.h"

namespace ves::training {

// The metrics of one session (definitions in docs/scoring.md), SI units. The
// same fields as ves.v1.SessionMetrics; ToProto() converts.
struct Metrics {
  double duration_s{0.0};
  bool completed{false};
  double time_to_cecum_s{0.0};  // 0 when not completed
  double inserted_at_cecum_m{0.0};  // inserted length at that moment; 0 when not completed
  double peak_insertion_force_N{0.0};
  double mean_insertion_force_N{0.0};
  std::uint32_t excessive_force_episodes{0};
  double excessive_force_s{0.0};
  double pain_s{0.0};
  double peak_stretch_m{0.0};
  double loop_s{0.0};
  std::uint32_t loop_count{0};
  double redout_s{0.0};
  double mucosa_seen_fraction{0.0};
  double xray_s{0.0};
  double tip_path_m{0.0};
  double max_insertion_m{0.0};
  double max_tip_arc_m{0.0};
  std::uint32_t damage_events{0};
  double damage_impulse_N_s{0.0};
  // The loop-control toolkit: how long the assistant's hand pressed each
  // site, how long the patient lay on each side, and how often the patient
  // was turned (from supine at the start).
  double press_llq_s{0.0};  // left lower quadrant
  double press_mid_s{0.0};  // mid-abdomen
  double left_lateral_s{0.0};
  double right_lateral_s{0.0};
  std::uint32_t position_changes{0};

  bool operator==(const Metrics&) const = default;
};

// Same numbering as ves.v1.EventKind.
enum class EventKind : int {
  kExcessiveForce = 1,
  kPain = 2,
  kLoop = 3,
  kDamage = 4,
  kRedout = 5,
  kViewMode = 6,
  kFluoroscopy = 7,
  kCecumReached = 8,
  kRepeat = 9,
};

// Something that happened during a session; `value`'s unit depends on the
// kind (docs/scoring.md): N for excessive force, m for pain and loops, N·s
// for damage, the new mode for view mode, 1/0 for fluoroscopy on/off.
struct Event {
  double t_s{0.0};
  EventKind kind{EventKind::kExcessiveForce};
  double duration_s{0.0};
  double arc_m{0.0};
  double value{0.0};
  std::string detail;

  bool operator==(const Event&) const = default;
};

// Loop index (docs/scoring.md): the scope's slack, inserted length minus the
// tip's arc position, above the lowest slack seen so far with the tip no
// deeper than now. It grows exactly when the inserted length grows while the
// tip's arc does not; a scope pulled back out after a deep reduction (slack
// far below zero there) does not count as a loop at the shallower depths.
class LoopIndex {
 public:
  // Returns the index after this step (m).
  double Update(double inserted_m, double tip_arc_m);
  double value() const { return value_; }

 private:
  static constexpr double kDepthBin_m = 0.01;
  static constexpr std::size_t kMaxBins = 1000;  // 10 m: beyond any colon
  // [b]: the lowest slack seen with the tip in depth bins 0..b (non-increasing in b).
  std::vector<double> min_slack_up_to_bin_;
  double value_{0.0};
};

// Accumulates every metric from step observations fed at the model rate.
// Pure: no clocks, no I/O; the same observations give the same metrics.
class MetricsAccumulator {
 public:
  explicit MetricsAccumulator(const MetricThresholds& thresholds);

  void Add(const StepObservation& observation);

  bool cecum_reached() const { return cecum_time_s_.has_value(); }
  double loop_index_m() const { return loop_index_.value(); }
  // Whether the scope is in a loop now (the hysteresis the loop time uses).
  bool in_loop() const { return in_loop_; }
  // The metrics and events so far, open episodes closed at the last step.
  Metrics Result() const;
  std::vector<Event> Events() const;
  // Damage per segment (N·s above the damage threshold), when observations
  // carried per-segment forces; indexed like StepObservation::segment_wall_force_N.
  const std::vector<double>& damage_map_N_s() const { return damage_map_N_s_; }
  const MetricThresholds& thresholds() const { return thresholds_; }

 private:
  MetricThresholds thresholds_;
  std::uint64_t steps_{0};
  double t_s_{0.0};
  double running_s_{0.0};
  std::optional<double> cecum_time_s_;
  double cecum_inserted_m_{0.0};
  double peak_force_N_{0.0};
  double force_integral_N_s_{0.0};
  // Forces are judged as their mean over kForceWindow_s (what a hand and a
  // force sensor resolve), so a 1-3 ms contact transient of the model does not
  // become the session's peak hand force or a damage event (docs/scoring.md).
  static constexpr double kForceWindow_s = 0.01;
  static constexpr int kForceWindowMaxSteps = 64;
  class WindowMean {
   public:
    // The mean of the last `window_steps` values (fewer at the start).
    double Add(double value, int window_steps);

   private:
    std::array<double, kForceWindowMaxSteps> values_{};
    int next_{0};
    int count_{0};
    double sum_{0.0};
  };
  WindowMean hand_force_window_;
  WindowMean wall_force_window_;  // of the largest wall force
  EpisodeTracker force_;
  EpisodeTracker pain_;
  EpisodeTracker loop_;
  EpisodeTracker redout_;
  EpisodeTracker damage_;
  LoopIndex loop_index_;
  bool in_loop_{false};
  double peak_stretch_m_{0.0};
  double mucosa_seen_{0.0};
  double xray_s_{0.0};
  double press_llq_s_{0.0};
  double press_mid_s_{0.0};
  double left_lateral_s_{0.0};
  double right_lateral_s_{0.0};
  std::uint32_t position_changes_{0};
  PatientPosition position_{PatientPosition::kSupine};  // every session starts supine
  double tip_path_m_{0.0};
  Eigen::Vector3d last_tip_{Eigen::Vector3d::Zero()};
  double max_inserted_m_{0.0};
  double max_tip_arc_m_{0.0};
  std::optional<ViewMode> view_mode_;
  std::optional<bool> fluoroscopy_on_;
  std::vector<Event> toggles_;  // view mode, fluoroscopy and cecum events, in time order
  std::vector<double> damage_map_N_s_;
};

}  // namespace ves::training
