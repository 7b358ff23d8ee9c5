#include "station/training/scripted_operator.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "station/training/observer.h"

namespace ves::training {
Perception Perceive(const model::ModelParams& params, const model::ModelState& state,
                    const model::StepOutput& output, double lumen_lookahead_m) {
  Perception p;
  p.t_s = state.time_s;
  p.inserted_m = state.inserted_m;
  p.tip_arc_m = state.tip_arc_m;
  p.base_force_N = output.base_force_N;
  p.peak_stretch_m = output.peak_stretch_m;
  const Eigen::Vector3d target_W =
      ColonPointAtArc(params, state, state.tip_arc_m + lumen_lookahead_m);
  const Eigen::Vector3d d_Tip = state.X_WTip.inverse() * target_W;
  if (d_Tip.norm() > 1e-9) p.lumen_Tip = d_Tip.normalized();
  p.angulation_up_rad = std::min(params.scope.angulation_up_rad, params.scope.angulation_down_rad);
  p.angulation_right_rad =
      std::min(params.scope.angulation_right_rad, params.scope.angulation_left_rad);
  return p;
}

InputSample NoviceOperator::Act(const Perception&) {
  InputSample in;
  in.thrust_mode = ThrustMode::kForce;
  in.push_force_N = kPushForce_N;
  in.view_mode = ViewMode::kWireframe;
  in.fluoroscopy_on = true;
  return in;
}

InputSample ExpertOperator::Act(const Perception& p) {
  const double loop_m = loop_index_.Update(p.inserted_m, p.tip_arc_m);
  // What the hand and the image tell: scope in beyond the path to the tip.
  const double slack_m = p.inserted_m - p.tip_arc_m;
  if (pushing_through_) {
    if (p.peak_stretch_m > kPainStretch_m) pain_s_ += dt_s_;
    if (slack_m > kPushThroughSlackLimit_m || pain_s_ > kPushThroughPainLimit_s) {
      pushing_through_ = false;
    }
  }
  const Technique& t = pushing_through_ ? kPushThrough : kGentle;

  if (!withdrawing_) {
    const bool loop = loop_m > t.loop_start_m || p.base_force_N > t.force_limit_N ||
                      p.peak_stretch_m > t.complaint_stretch_m;
    const bool stalled =
        p.t_s - window_start_s_ >= kStallWindow_s && p.tip_arc_m - window_arc_m_ < kStallAdvance_m;
    if (p.t_s - window_start_s_ >= kStallWindow_s) {
      window_start_s_ = p.t_s;
      window_arc_m_ = p.tip_arc_m;
    }
    if (!pushing_through_ && stalled && !loop && slack_m < kTorqueSlack_m) {
      // Nothing to pull out: torque the shaft while pushing on.
      torque_until_s_ = p.t_s + kTorque_s;
      roll_direction_ = -roll_direction_;
    } else if (loop || stalled) {
      withdrawing_ = true;
      phase_start_s_ = p.t_s;
      loop_at_start_m_ = loop_m;
      roll_direction_ = -roll_direction_;  // alternate the torque between attempts
    }
  } else if (const double elapsed_s = p.t_s - phase_start_s_;
             elapsed_s >= kWithdrawMax_s || slack_m < kStraightSlack_m ||
             (elapsed_s >= kWithdraw_s && p.base_force_N < 0.5 * t.force_limit_N &&
              p.peak_stretch_m < 0.5 * t.complaint_stretch_m &&
              loop_m < std::max(kLoopDone_m, 0.5 * loop_at_start_m_))) {
    withdrawing_ = false;
    window_start_s_ = p.t_s;
    window_arc_m_ = p.tip_arc_m;
  }

  InputSample in;
  in.thrust_mode = ThrustMode::kForce;
  in.view_mode = ViewMode::kTextured;
  in.fluoroscopy_on = false;
  if (withdrawing_) {
    in.push_force_N = slack_m < kRelaxHandSlack_m ? 0.0 : kPullForce_N;
    roll_rad_ += roll_direction_ * kRollRate_rad_per_s * dt_s_;
    const double relax = std::max(0.0, 1.0 - kKnobRelax_per_s * dt_s_);
    knob_up_rad_ *= relax;
    knob_right_rad_ *= relax;
  } else {
    // Steer: turn the knobs so the lumen moves to the image centre.
    const double up_error_rad = std::atan2(p.lumen_Tip.y(), p.lumen_Tip.z());
    const double right_error_rad = std::atan2(p.lumen_Tip.x(), p.lumen_Tip.z());
    knob_up_rad_ = std::clamp(knob_up_rad_ + kSteerGain_per_s * up_error_rad * dt_s_,
                              -p.angulation_up_rad, p.angulation_up_rad);
    knob_right_rad_ = std::clamp(knob_right_rad_ + kSteerGain_per_s * right_error_rad * dt_s_,
                                 -p.angulation_right_rad, p.angulation_right_rad);
    // Push less while the lumen is off the view axis.
    const double off_axis_rad = std::acos(std::clamp(p.lumen_Tip.z(), -1.0, 1.0));
    in.push_force_N = t.push_N * std::clamp(1.0 - off_axis_rad / 1.2, 0.2, 1.0);
    if (p.t_s < torque_until_s_) roll_rad_ += roll_direction_ * kRollRate_rad_per_s * dt_s_;
  }
  in.roll_rad = roll_rad_;
  in.knob_up_rad = knob_up_rad_;
  in.knob_right_rad = knob_right_rad_;
  return in;
}

std::unique_ptr<ScriptedOperator> MakeScriptedOperator(std::string_view kind, double dt_s) {
  if (kind == "novice") return std::make_unique<NoviceOperator>();
  if (kind == "expert") return std::make_unique<ExpertOperator>(dt_s);
  throw std::invalid_argument("operator must be novice or expert, got '" + std::string(kind) + "'");
}

}  // namespace ves::training
