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
  // How much scope is in beyond the shortest it has been for this depth: the
  // loop, as the insertion that did not move the image tells it.
  const double loop_m = loop_index_.Update(p.inserted_m, p.tip_arc_m);
  if (!reducing_) {
    StartAPullBackIfNeeded(p, loop_m);
  } else {
    EndThePullBackIfDone(p);
  }
  TendThePatient(p);
  return MoveTheHands(p);
}

void ExpertOperator::StartAPullBackIfNeeded(const Perception& p, double loop_m) {
  const Settings& k = settings_;
  const bool scope_used_up = p.inserted_m > p.working_length_m - kScopeLeft_m;
  const bool deeper = p.tip_arc_m > last_reduce_tip_m_ + kReduceAgainDepth_m;
  // A pull-back that found the tip loose waits only until the tip is a
  // little deeper, where it may be round the next corner.
  const bool past_loose = p.tip_arc_m > loose_tip_m_ + kReprobeDepth_m;
  if (p.tip_arc_m > stall_tip_m_ + kStallAdvance_m) {
    stall_tip_m_ = p.tip_arc_m;
    stall_since_s_ = p.t_s;
  }
  // Stalled (the tip has not moved for kStall_s) while the patient does
  // not complain: the tip is against a wall, not stretching a loop (a tip
  // stalled in mobile colon that stretches it is pushed on through).
  const bool stalled =
      p.t_s - stall_since_s_ > kStall_s && p.peak_stretch_m < kComplaintStretch_m;
  // Stalled, it pulls back to straighten the scope whatever the loop index reads, once per
  // kReduceAgainDepth_m of depth: repeated pull-backs at one place pressed
  // the rectosigmoid (redundant-sigmoid, docs/scoring.md).
  const bool stall_reduce = stalled && p.tip_arc_m > last_stall_reduce_tip_m_ + kReduceAgainDepth_m;
  if (stall_reduce) last_stall_reduce_tip_m_ = p.tip_arc_m;
  // Stalled in the sigmoid while the patient complains: the push stretches
  // a sigmoid loop that holds the tip back; it asks for help. (A pull-back
  // there took the scope so short that the colon gathered onto it held the
  // tip, and for a transverse loop the turn cost generated seed 10 its cecum.)
  if (p.t_s - stall_since_s_ > kStall_s && p.peak_stretch_m >= kComplaintStretch_m &&
      p.tip_arc_m < kSigmoidTip_m) {
    stall_since_s_ = p.t_s;
    CallForHelp(p);
  }
  // More scope in than a straight route needs: a loop the loop index has
  // not seen (it counts from the shortest insertion for this depth, and a
  // reduction that slipped resets that).
  const bool looped_by_length = p.inserted_m > kLoopedLength_m && past_loose &&
                                p.tip_arc_m > last_reduce_tip_m_ + kLengthReduceAgainDepth_m;
  const bool loop_reading = deeper && past_loose && loop_m > k.loop_limit_m;
  const bool reduce = loop_reading || looped_by_length ||
                      (scope_used_up && past_loose && (deeper || stalled)) || stall_reduce;
  // Stalled again where it already pulled back: it backs the tip off a
  // little and steers again ("pull back to find the lumen"), once per
  // kBackOffAgainDepth_m of depth (a tip that the back-off did not free
  // goes on under the hand's steady push); a back-off is not a reduction,
  // so the next one still waits only for depth.
  const bool back_off =
      !reduce && stalled && p.tip_arc_m > last_back_off_tip_m_ + kBackOffAgainDepth_m;
  if (back_off) last_back_off_tip_m_ = p.tip_arc_m;
  if (reduce || back_off) {
    reducing_ = true;
    backing_off_ = back_off;
    stall_since_s_ = p.t_s;
    length_reduce_ = looped_by_length && !loop_reading && !scope_used_up && !stall_reduce;
    reduce_start_s_ = p.t_s;
    reduce_start_inserted_m_ = p.inserted_m;
    reduce_start_loop_m_ = loop_m;
    reduce_tip_max_m_ = p.tip_arc_m;
  }
}

void ExpertOperator::EndThePullBackIfDone(const Perception& p) {
  const Settings& k = settings_;
  // The loop is out once the tip comes back with the scope (insertion and
  // image move one to one again); also stop after a long pull or a while,
  // and a reduction for the length alone once the length is well under it.
  reduce_tip_max_m_ = std::max(reduce_tip_max_m_, p.tip_arc_m);
  const double withdrawn_m = reduce_start_inserted_m_ - p.inserted_m;
  const bool tip_back = p.tip_arc_m < reduce_tip_max_m_ - kTipBack_m;
  if (tip_back || withdrawn_m > (backing_off_ ? kBackOff_m : k.max_withdraw_m) ||
      p.t_s - reduce_start_s_ > k.max_reduce_s ||
      (length_reduce_ && p.inserted_m < kLoopedLength_m - kLoopedLengthMargin_m)) {
    reducing_ = false;
    settle_until_s_ = p.t_s + k.settle_s;
    if (!backing_off_) {
      // The tip came back with the scope before the loop gave: the tip is
      // not anchored beyond the loop, and turning the shaft did not take the
      // loop out. The loop resists; the assistant's hand or the patient's
      // position must hold the colon while the scope advances.
      const bool loose = tip_back && withdrawn_m < kLoosePull_m + kTipBack_m;
      if (loose) {
        loose_tip_m_ = p.tip_arc_m;
        if (reduce_start_loop_m_ > k.loop_limit_m) CallForHelp(p);
      } else {
        last_reduce_tip_m_ = reduce_tip_max_m_;
      }
    }
  }
}

void ExpertOperator::TendThePatient(const Perception& p) {
  // Turned, a patient who complains for kTurnedComplaint_s is turned back
  // onto the back, and not onto that side again.
  if (position_ != PatientPosition::kSupine) {
    if (p.peak_stretch_m < kComplaintStretch_m) complaint_since_s_ = p.t_s;
    if (p.t_s - complaint_since_s_ > kTurnedComplaint_s) {
      refused_position_ = position_;
      position_ = PatientPosition::kSupine;
    }
  }
  // The assistant keeps pressing until the tip is well past where the loop
  // formed, then lets go.
  if (press_ != AbdominalPress::kNone &&
      (p.tip_arc_m > press_until_tip_m_ || p.t_s > press_until_s_)) {
    press_ = AbdominalPress::kNone;
  }
}

InputSample ExpertOperator::MoveTheHands(const Perception& p) {
  const Settings& k = settings_;
  InputSample in;
  in.thrust_mode = ThrustMode::kForce;
  in.view_mode = ViewMode::kTextured;
  in.fluoroscopy_on = false;
  in.abdominal_press = press_;
  in.patient_position = position_;
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

void ExpertOperator::CallForHelp(const Perception& p) {
  // Where the loop is, judged by how far the image shows the tip to be: short
  // of kSigmoidTip_m the scope bows the sigmoid, and the assistant presses
  // over the left lower quadrant, then the patient is turned if that loop
  // resists again; deeper the transverse colon sags, and the patient is
  // turned first, then the assistant presses mid-abdomen.
  const bool sigmoid = p.tip_arc_m < kSigmoidTip_m;
  const AbdominalPress where =
      sigmoid ? AbdominalPress::kLeftLowerQuadrant : AbdominalPress::kMidAbdomen;
  const PatientPosition turn_to =
      sigmoid ? PatientPosition::kRightLateral : PatientPosition::kLeftLateral;
  const bool turned_here = position_ == turn_to;
  const bool pressed_here = pressed_before_ == where;  // set with every press
  if (sigmoid ? !pressed_here : turned_here) {
    press_ = where;
    pressed_before_ = where;
    press_until_tip_m_ = p.tip_arc_m + kPressHoldDepth_m;
    press_until_s_ = p.t_s + kPressHold_s;
  } else if (turn_to != refused_position_) {
    position_ = turn_to;
    complaint_since_s_ = p.t_s;
  }
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
