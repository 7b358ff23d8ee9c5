#pragma once

#include <vector>

namespace ves::training {

// One stretch of time during which a quantity stayed over its threshold.
struct Episode {
  double start_s{0.0};          // start of the first over-threshold step
  double duration_s{0.0};       // sum of the over-threshold steps' dt (merge gaps not counted)
  double peak_value{0.0};       // largest value seen during the episode
  double peak_arc_m{0.0};       // where along the colon the peak happened
  double excess_integral{0.0};  // integral of (value - threshold) dt over the episode

  bool operator==(const Episode&) const = default;
};

// Turns a per-step "over threshold" signal into episodes. Two over-threshold
// runs separated by less than `merge_gap_s` are one episode, so a force
// jittering around its threshold does not count as many.
class EpisodeTracker {
 public:
  explicit EpisodeTracker(double merge_gap_s);

  // One step covering (t_s - dt_s, t_s]. `excess` is value - threshold (only
  // integrated when over).
  void Update(double t_s, double dt_s, bool over, double value, double arc_m, double excess);
  // Closes the open episode, if any.
  void Finish();

  const std::vector<Episode>& episodes() const { return episodes_; }
  // Time over the threshold, open episode included.
  double total_s() const { return total_s_; }
  bool in_episode() const { return open_; }

 private:
  void Close();

  double merge_gap_s_;
  bool open_{false};
  double last_over_end_s_{0.0};
  Episode current_;
  std::vector<Episode> episodes_;
  double total_s_{0.0};
};

}  // namespace ves::training
