#include "station/training/episode_tracker.h"

#include <stdexcept>
#include <string>

namespace ves::training {

EpisodeTracker::EpisodeTracker(double merge_gap_s) : merge_gap_s_(merge_gap_s) {
  if (!(merge_gap_s >= 0.0)) {
    throw std::invalid_argument("EpisodeTracker: merge_gap_s must be >= 0, got " +
                                std::to_string(merge_gap_s));
  }
}

void EpisodeTracker::Update(double t_s, double dt_s, bool over, double value, double arc_m,
                            double excess) {
  const double step_start_s = t_s - dt_s;
  // Consecutive steps have a gap of ~0 (rounding); a skipped step makes it dt.
  const double gap_s = step_start_s - last_over_end_s_;
  if (open_ && gap_s > 0.5 * dt_s && gap_s >= merge_gap_s_) Close();
  if (!over) return;
  if (!open_) {
    open_ = true;
    current_ = Episode{.start_s = step_start_s, .peak_value = value, .peak_arc_m = arc_m};
  }
  current_.duration_s += dt_s;
  current_.excess_integral += excess * dt_s;
  if (value > current_.peak_value) {
    current_.peak_value = value;
    current_.peak_arc_m = arc_m;
  }
  total_s_ += dt_s;
  last_over_end_s_ = t_s;
}

void EpisodeTracker::Finish() {
  if (open_) Close();
}

void EpisodeTracker::Close() {
  episodes_.push_back(current_);
  open_ = false;
}

}  // namespace ves::training
