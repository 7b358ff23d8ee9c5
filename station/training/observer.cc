#include "station/training/observer.h"

#include <algorithm>
#include <cmath>

namespace ves::training {

Observer::Observer(const model::ModelParams& params)
    : dt_s_(params.dt_s), seen_(params.colon.points.size(), 0) {
  arc_m_.reserve(params.colon.points.size());
  for (const auto& p : params.colon.points) arc_m_.push_back(p.arc_m);
}

void Observer::Reset() {
  std::fill(seen_.begin(), seen_.end(), 0);
  seen_count_ = 0;
}

StepObservation Observer::Observe(const InputSample& input, const model::ModelState& state,
                                  const model::StepOutput& out) {
  StepObservation o;
  o.dt_s = dt_s_;
  o.t_s = static_cast<double>(input.tick + 1) * dt_s_;
  o.inserted_m = out.inserted_m;
  o.tip_arc_m = out.tip_arc_m;
  o.base_force_N = out.base_force_N;
  o.p_WTip = out.X_WTip.translation();
  o.peak_stretch_m = out.peak_stretch_m;
  o.peak_stretch_arc_m = out.peak_stretch_arc_m;
  o.segment_wall_force_N = out.wall_force_N;
  o.segment_arc_m = arc_m_;
  const auto peak = std::max_element(out.wall_force_N.begin(), out.wall_force_N.end());
  if (peak != out.wall_force_N.end()) {
    o.max_wall_force_N = *peak;
    o.max_wall_force_arc_m = arc_m_[static_cast<std::size_t>(peak - out.wall_force_N.begin())];
  }
  o.view_mode = input.view_mode;
  o.fluoroscopy_on = input.fluoroscopy_on;
  o.abdominal_press = input.abdominal_press;
  o.patient_position = input.patient_position;

  const Eigen::Vector3d axis_W = out.X_WTip.linear().col(2);
  const int tip_sample = static_cast<int>(state.samples.size()) - 1;
  for (int c = 0; c < out.contact_count; ++c) {
    const model::Contact& contact = out.contacts[c];
    if (contact.sample == tip_sample && contact.penetration_m > 0.0 &&
        axis_W.dot(contact.normal_W) > kRedoutCos) {
      o.redout_fraction = 1.0;
    }
  }

  const double cos_half = std::cos(kViewHalfAngle_rad);
  for (std::size_t i = 0; i < state.p_WColon.size(); ++i) {
    if (seen_[i]) continue;
    const Eigen::Vector3d d = state.p_WColon[i] - o.p_WTip;
    const double distance_m = d.norm();
    if (distance_m < kViewRange_m && distance_m > 0.0 && axis_W.dot(d) > cos_half * distance_m) {
      seen_[i] = 1;
      ++seen_count_;
    }
  }
  o.mucosa_seen_fraction =
      seen_.empty() ? 0.0 : static_cast<double>(seen_count_) / static_cast<double>(seen_.size());
  return o;
}

Eigen::Vector3d ColonPointAtArc(const model::ModelParams& params, const model::ModelState& state,
                                double arc_m) {
  const auto& pts = params.colon.points;
  if (arc_m <= pts.front().arc_m) return state.p_WColon.front();
  if (arc_m >= pts.back().arc_m) return state.p_WColon.back();
  const auto it =
      std::upper_bound(pts.begin(), pts.end(), arc_m,
                       [](double a, const model::ColonPoint& p) { return a < p.arc_m; });
  const std::size_t k = static_cast<std::size_t>(it - pts.begin()) - 1;
  const double t = (arc_m - pts[k].arc_m) / (pts[k + 1].arc_m - pts[k].arc_m);
  return (1.0 - t) * state.p_WColon[k] + t * state.p_WColon[k + 1];
}

Eigen::Vector3d ColonPointAhead(const model::ModelParams& params, const model::ModelState& state,
                                double arc_m, double ahead_m) {
  const auto& pts = params.colon.points;
  const std::size_t n = pts.size();
  if (arc_m >= pts.back().arc_m) return state.p_WColon.back();
  const auto it =
      std::upper_bound(pts.begin(), pts.end(), std::max(arc_m, pts.front().arc_m),
                       [](double a, const model::ColonPoint& p) { return a < p.arc_m; });
  std::size_t k = static_cast<std::size_t>(it - pts.begin()) - 1;
  const double t = (std::max(arc_m, pts.front().arc_m) - pts[k].arc_m) /
                   (pts[k + 1].arc_m - pts[k].arc_m);
  Eigen::Vector3d from = (1.0 - t) * state.p_WColon[k] + t * state.p_WColon[k + 1];
  double left_m = ahead_m;
  for (++k; k < n; ++k) {
    const double step_m = (state.p_WColon[k] - from).norm();
    if (step_m >= left_m) return from + (left_m / step_m) * (state.p_WColon[k] - from);
    left_m -= step_m;
    from = state.p_WColon[k];
  }
  return state.p_WColon.back();
}

}  // namespace ves::training
