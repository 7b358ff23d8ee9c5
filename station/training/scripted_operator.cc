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
      ColonPointAhead(params, state, state.tip_arc_m, lumen_lookahead_m);
  const Eigen::Vector3d d_Tip = state.X_WTip.inverse() * target_W;
  if (d_Tip.norm() > 1e-9) p.lumen_Tip = d_Tip.normalized();
  p.angulation_up_rad = std::min(params.scope.angulation_up_rad, params.scope.angulation_down_rad);
  p.angulation_right_rad =
      std::min(params.scope.angulation_right_rad, params.scope.angulation_left_rad);
  p.working_length_m = params.scope.working_length_m;
  const auto& pts = params.colon.points;
  auto at = std::upper_bound(
      pts.begin(), pts.end(), state.tip_arc_m,
      [](double arc_m, const model::ColonPoint& point) { return arc_m < point.arc_m; });
  if (at != pts.begin()) --at;  // the last point at or before the tip
  if (!at->tissue.mobile) {
    auto start = at;
    while (start != pts.begin() && !(start - 1)->tissue.mobile) --start;
    p.tip_into_fixed_colon_m = state.tip_arc_m - start->arc_m;
  }
  return p;
}

void SteerTowardTheLumen(const Perception& perception, double gain_per_s, double dt_s,
                         double* knob_up_rad, double* knob_right_rad) {
  const Eigen::Vector3d& lumen = perception.lumen_Tip;
  const double up_error_rad = std::atan2(lumen.y(), lumen.z());
  const double right_error_rad = std::atan2(lumen.x(), lumen.z());
  *knob_up_rad = std::clamp(*knob_up_rad + gain_per_s * up_error_rad * dt_s,
                            -perception.angulation_up_rad, perception.angulation_up_rad);
  *knob_right_rad = std::clamp(*knob_right_rad + gain_per_s * right_error_rad * dt_s,
                               -perception.angulation_right_rad, perception.angulation_right_rad);
}

void LimitKnobBend(double max_bend_rad, double* knob_up_rad, double* knob_right_rad) {
  const double bend_rad = std::hypot(*knob_up_rad, *knob_right_rad);
  if (bend_rad > max_bend_rad) {
    *knob_up_rad *= max_bend_rad / bend_rad;
    *knob_right_rad *= max_bend_rad / bend_rad;
  }
}

InputSample NoviceOperator::Act(const Perception&) {
  InputSample in;
  in.thrust_mode = ThrustMode::kForce;
  in.push_force_N = push_force_N_;
  in.view_mode = ViewMode::kWireframe;
  in.fluoroscopy_on = true;
  return in;
}

InputSample ExpertOperator::Act(const Perception& p) {
  if (!started_) {
    started_ = true;
    last_inserted_m_ = p.inserted_m;
  }
  const Settings& k = settings_;
  // How much scope is in beyond the shortest it has been for this depth: the
  // loop, as the insertion that did not move the image tells it.
  const double loop_m = loop_index_.Update(p.inserted_m, p.tip_arc_m);
  if (!reducing_) {
    // Only with the tip hooked in fixed colon can a loop be taken out (or
    // when the scope is nearly all in); and not again before the tip has
    // gone deeper than at the last reduction.
    const bool hooked = p.tip_into_fixed_colon_m >= kHookDepth_m;
    const bool scope_used_up = p.inserted_m > p.working_length_m - kScopeLeft_m;
    const bool deeper = p.tip_arc_m > last_reduce_tip_m_ + kReduceAgainDepth_m;
    if (p.tip_arc_m > stall_tip_m_ + kStallAdvance_m) {
      stall_tip_m_ = p.tip_arc_m;
      stall_since_s_ = p.t_s;
    }
    const bool stalled = p.t_s - stall_since_s_ > kStall_s;
    // Stalled in fixed colon (the tip has not moved for kStall_s), it pulls
    // back to straighten the scope even without a hook or a loop reading,
    // once per kReduceAgainDepth_m of depth: repeated pull-backs at one
    // place pressed the rectosigmoid (redundant-sigmoid, docs/scoring.md).
    const bool stalled_in_fixed = stalled && p.tip_into_fixed_colon_m > 0.0;
    const bool stall_reduce =
        stalled_in_fixed && p.tip_arc_m > last_stall_reduce_tip_m_ + kReduceAgainDepth_m;
    if (stall_reduce) last_stall_reduce_tip_m_ = p.tip_arc_m;
    // Hooked with more scope in than a straight route needs: a loop the
    // loop index has not seen (it counts from the shortest insertion for this
    // depth, and a reduction that slipped resets that).
    const bool looped_by_length =
        hooked && p.inserted_m > kLoopedLength_m &&
        p.tip_arc_m > last_reduce_tip_m_ + kLengthReduceAgainDepth_m;
    const bool loop_reading = deeper && hooked && loop_m > k.loop_limit_m;
    const bool reduce = loop_reading || looped_by_length ||
                        (scope_used_up && (deeper || stalled)) || stall_reduce;
    // Stalled again in fixed colon where it already pulled back: it backs the
    // tip off a little and steers again ("pull back to find the lumen"); a
    // back-off is not a reduction, so the next one still waits only for depth.
    const bool back_off = !reduce && stalled_in_fixed;
    if (reduce || back_off) {
      reducing_ = true;
      backing_off_ = back_off;
      stall_since_s_ = p.t_s;
      if (reduce) last_reduce_tip_m_ = p.tip_arc_m;
      length_reduce_ = looped_by_length && !loop_reading && !scope_used_up && !stall_reduce;
      reduce_start_s_ = p.t_s;
      reduce_start_inserted_m_ = p.inserted_m;
      reduce_tip_max_m_ = p.tip_arc_m;
    }
  } else {
    // The loop is out once the tip comes back with the scope (insertion and
    // image move one to one again); also stop after a long pull or a while,
    // and a reduction for the length alone once the length is well under it.
    reduce_tip_max_m_ = std::max(reduce_tip_max_m_, p.tip_arc_m);
    if (p.tip_arc_m < reduce_tip_max_m_ - kTipBack_m ||
        reduce_start_inserted_m_ - p.inserted_m > (backing_off_ ? kBackOff_m : k.max_withdraw_m) ||
        p.t_s - reduce_start_s_ > k.max_reduce_s ||
        (length_reduce_ && p.inserted_m < kLoopedLength_m - kLoopedLengthMargin_m)) {
      reducing_ = false;
      settle_until_s_ = p.t_s + k.settle_s;
    }
  }

  InputSample in;
  in.thrust_mode = ThrustMode::kForce;
  in.view_mode = ViewMode::kTextured;
  in.fluoroscopy_on = false;
  double target_speed_m_per_s = 0.0;
  if (reducing_) {
    // Tip hooked (knobs held), withdraw and turn clockwise (+ roll about the
    // insertion axis, seen from the endoscopist).
    target_speed_m_per_s = -k.withdraw_speed_m_per_s;
    if (!backing_off_) {
      roll_rad_ = std::min(kMaxRoll_rad, roll_rad_ + k.roll_rate_rad_per_s * dt_s_);
    }
  } else {
    // Steer: turn the knobs so the lumen moves to the image centre, never
    // past kKnobMax_rad (a tip bent further only hooks the wall).
    SteerTowardTheLumen(p, kSteerGain_per_s, dt_s_, &knob_up_rad_, &knob_right_rad_);
    LimitKnobBend(kKnobMax_rad, &knob_up_rad_, &knob_right_rad_);
    if (p.t_s < settle_until_s_) {
      target_speed_m_per_s = 0.0;  // settling: hold still, the shaft kept turned
    } else {
      target_speed_m_per_s = k.advance_speed_m_per_s;
      roll_rad_ *= std::max(0.0, 1.0 - kRollRelax_per_s * dt_s_);
    }
  }
  // The hand: its force follows the speed error, within its limits.
  const double speed_m_per_s = (p.inserted_m - last_inserted_m_) / dt_s_;
  last_inserted_m_ = p.inserted_m;
  hand_N_ =
      std::clamp(hand_N_ + kHandGain_N_s_per_m * (target_speed_m_per_s - speed_m_per_s) * dt_s_,
                 -k.pull_limit_N, k.push_limit_N);
  in.push_force_N = hand_N_;
  in.roll_rad = roll_rad_;
  in.knob_up_rad = knob_up_rad_;
  in.knob_right_rad = knob_right_rad_;
  return in;
}

std::unique_ptr<ScriptedOperator> MakeScriptedOperator(std::string_view kind, double dt_s,
                                                       const ExpertOperator::Settings& expert) {
  if (kind == "novice") return std::make_unique<NoviceOperator>();
  if (kind == "expert") return std::make_unique<ExpertOperator>(dt_s, expert);
  throw std::invalid_argument("operator must be novice or expert, got '" + std::string(kind) + "'");
}

std::unique_ptr<ScriptedOperator> MakeScriptedOperator(std::string_view kind, double dt_s) {
  return MakeScriptedOperator(kind, dt_s, ExpertOperator::Settings{});
}

}  // namespace ves::training
