#pragma once

#include <vector>

#include "station/model/model.h"
#include "station/training/input_log.h"
#include "station/training/observation.h"

namespace ves::training {

// Turns the model's state and step output into a StepObservation (what the
// metrics need), from the model alone so that replay reproduces it without
// rendering; red-out and mucosa seen are geometric (docs/scoring.md):
//  - red-out: the tip sample touches the wall while the camera axis points
//    into it (within 60 degrees of the wall normal);
//  - mucosa seen: a colon segment point counts as seen once it has been
//    within kViewRange_m of the tip camera and inside its 70-degree half-angle
//    field of view (a wide-angle colonoscope lens).
class Observer {
 public:
  static constexpr double kViewRange_m = 0.06;
  static constexpr double kViewHalfAngle_rad = 70.0 * model::kPi / 180.0;
  static constexpr double kRedoutCos = 0.5;  // cos 60 deg

  explicit Observer(const model::ModelParams& params);

  // After the model step of `input` (tick = step index), with t_s = (tick + 1) dt.
  StepObservation Observe(const InputSample& input, const model::ModelState& state,
                          const model::StepOutput& output);
  void Reset();

  const std::vector<double>& segment_arc_m() const { return arc_m_; }

 private:
  double dt_s_;
  std::vector<double> arc_m_;
  std::vector<char> seen_;
  int seen_count_{0};
};

// Point on the current (deformed) colon centerline at rest arc `arc_m`
// (clamped to the colon), interpolated between segment points.
Eigen::Vector3d ColonPointAtArc(const model::ModelParams& params, const model::ModelState& state,
                                double arc_m);

// The point of the deformed centerline a path length ahead_m beyond the
// colon's material at arc_m, measured along the centerline as it is now (a
// pleated colon packs more material into the same view; a stretched one
// less): where the lumen ahead appears to someone looking from there.
Eigen::Vector3d ColonPointAhead(const model::ModelParams& params, const model::ModelState& state,
                                double arc_m, double ahead_m);

}  // namespace ves::training
