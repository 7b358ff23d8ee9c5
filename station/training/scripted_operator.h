#pragma once

#include <Eigen/Core>
#include <memory>
#include <string>
#include <string_view>

#include "station/model/model.h"
#include "station/training/input_log.h"
#include "station/training/metrics.h"

namespace ves::training {

// What a person at the station perceives after a model step: the hand's
// force, how far the scope is in, where the lumen appears in the endoscope
// image and how far along the colon the image shows the tip to be.
struct Perception {
  double t_s{0.0};
  double inserted_m{0.0};
  double tip_arc_m{0.0};
  double base_force_N{0.0};  // reaction felt by the hand, + resists insertion
  // How far the bowel is stretched: the patient's complaints (paper §3.3.1).
  double peak_stretch_m{0.0};
  // Direction of the lumen 4 cm ahead of the tip in the camera frame (+z the
  // view axis, +y image up, +x image right): where the dark hole is in the image.
  Eigen::Vector3d lumen_Tip{Eigen::Vector3d::UnitZ()};
  double angulation_up_rad{model::kPi};  // knob limits of the scope in hand
  double angulation_right_rad{model::kPi};
  double working_length_m{0.0};  // of the scope in hand
};

// How far ahead of the tip the image shows the lumen: the deformed centerline
// at this arc beyond the tip.
inline constexpr double kLumenLookahead_m = 0.04;

Perception Perceive(const model::ModelParams& params, const model::ModelState& state,
                    const model::StepOutput& output, double lumen_lookahead_m = kLumenLookahead_m);

// The simple steering rule: each knob turns toward the lumen at gain_per_s
// (rad/s) per radian of the lumen's offset from the image centre, within the
// scope's angulation. The expert steers with it, and so do the model tests'
// and insertion_probe's position-driven insertions.
void SteerTowardTheLumen(const Perception& perception, double gain_per_s, double dt_s,
                         double* knob_up_rad, double* knob_right_rad);

// A hand that turns the knobs no further than max_bend_rad in all: a larger
// bend is scaled back along its own direction (the expert's kKnobMax_rad;
// insertion_probe's PROBE_KNOB_MAX).
void LimitKnobBend(double max_bend_rad, double* knob_up_rad, double* knob_right_rad);

// A scripted trainee: produces the same InputSample a person's hands produce
// (for tests, demos and calibration, docs/scoring.md). Deterministic.
class ScriptedOperator {
 public:
  virtual ~ScriptedOperator() = default;
  virtual InputSample Act(const Perception& perception) = 0;
};

// Pushes with a steady force, leaves the knobs alone (ignores the lumen),
// watches the fluoroscopy all the time and uses the wireframe view. The
// "novice" of the sessions and tests pushes kPushForce_N; a harder push gets
// further on some colons (docs/scoring.md, "Known gaps").
class NoviceOperator final : public ScriptedOperator {
 public:
  static constexpr double kPushForce_N = 6.0;
  explicit NoviceOperator(double push_force_N = kPushForce_N) : push_force_N_(push_force_N) {}
  InputSample Act(const Perception& perception) override;

 private:
  double push_force_N_;
};

// The technique of an experienced endoscopist (docs/scoring.md, "Scripted
// operators"), from what a trainee at the station can know: the hand's force,
// the scope's length in, the image (where the lumen is, how far the tip
// moves) and its own hands; never the case's anatomy. It steers the tip
// toward the lumen with the knobs and advances gently. It recognises a loop
// as insertion without tip motion (the loop index) and reduces it: knobs
// held, it pulls back and turns the shaft clockwise, so the loop comes out
// and the colon pleats onto the scope while the tip holds. A tip that comes
// back with the scope at once is not anchored beyond the loop: it pushes on
// and tries again deeper, and if the loop was large it asks for help: the
// assistant presses the abdomen over the sigmoid or the patient is turned
// for the transverse colon, then the other if that loop resists again
// (CallForHelp); so does a tip stalled in the sigmoid while the patient
// complains. It stops pulling once the tip
// starts to come back with the scope (the loop is out), and advances again.
// When more scope is in than a straight route needs (kLoopedLength_m), when
// little scope is left, or when the tip has stalled, it takes the loops out
// too. Fluoroscopy off, textured view.
class ExpertOperator final : public ScriptedOperator {
 public:
  // The main settings; each must keep the expert working when moved by 20 %.
  // The hand moves the scope at a comfortable speed and never uses more
  // than its force limits (a speed-tracking hand: the force it applies
  // rises until the scope moves at that speed or the limit is reached).
  struct Settings {
    double advance_speed_m_per_s{0.01};   // while advancing
    double withdraw_speed_m_per_s{0.01};  // while reducing a loop
    // Most the hand pushes: 10 N, the level real endoscopists' hands stay
    // under 95 % of the time (peak push about 43 N; Appleyard et al., GIE
    // 2000). A limit of 8 N moved by -20 % (6.4 N) stalls at the sigmoid-
    // descending junction of standard-adult, which takes between 6.4 and 6.6 N
    // (docs/model-shortening-notes.md, "The hand's push limit").
    double push_limit_N{10.0};
    double pull_limit_N{8.0};             // most the hand pulls
    // Loop index (scope in beyond the shortest it has been for this depth,
    // LoopIndex) at which it reduces, once the tip is hooked in fixed colon.
    double loop_limit_m{0.10};
    double roll_rate_rad_per_s{0.5};  // clockwise turn of the shaft while reducing
    // After a reduction it holds still this long, the shaft turned, so the
    // colon settles onto the straightened scope before it pushes on.
    double settle_s{0.0};
    // A reduction ends after this much withdrawal or this long at most (the
    // loop is out sooner once the tip comes back). Not among the main
    // settings: docs/model-shortening-notes.md, "A lumen that gathers onto
    // the scope", measures longer ones.
    double max_withdraw_m{0.30};
    double max_reduce_s{40.0};
    bool operator==(const Settings&) const = default;
  };
  static constexpr double kSteerGain_per_s = 8.0;  // knob angle rate per radian of lumen offset
  static constexpr double kKnobMax_rad = 2.0;      // the hand turns the knobs no further
  static constexpr double kHandGain_N_s_per_m = 200.0;  // force rate per speed error
  // A pull-back whose tip comes kTipBack_m back within this much more
  // withdrawal found the tip loose (not anchored beyond the loop); it tries
  // again once the tip is kReprobeDepth_m deeper.
  static constexpr double kLoosePull_m = 0.02;
  static constexpr double kReprobeDepth_m = 0.10;
  // A loop that resists with the tip short of this (as the image shows the
  // tip's progress) is in the sigmoid, beyond it in the transverse colon.
  static constexpr double kSigmoidTip_m = 0.80;
  // The assistant presses until the tip is this much deeper than where the
  // loop resisted, or this long at most (a hand pressing for minutes tires,
  // and a press that has not helped by then hurts).
  static constexpr double kPressHoldDepth_m = 0.30;
  static constexpr double kPressHold_s = 60.0;
  // A turned patient who complains this long is turned back.
  static constexpr double kTurnedComplaint_s = 10.0;
  // After a reduction, the next waits until the tip is this much deeper: a
  // loop re-formed by pushing on is taut before the tip moves again.
  static constexpr double kReduceAgainDepth_m = 0.10;
  // With this little scope left outside, the loops must come out: once the
  // tip is deeper than at the last reduction, or has stalled this long.
  static constexpr double kScopeLeft_m = 0.08;
  static constexpr double kStall_s = 15.0;
  // The patient complains of a stretch beyond this (MetricThresholds::pain_stretch_m).
  static constexpr double kComplaintStretch_m = 0.02;
  static constexpr double kStallAdvance_m = 0.005;
  static constexpr double kTipBack_m = 0.015;     // the tip coming back this far: loop out
  // Stalled again where it has already pulled back, it only backs the tip
  // off the wall this far (no roll) and steers on.
  static constexpr double kBackOff_m = 0.03;
  static constexpr double kBackOffAgainDepth_m = 0.05;
  // More scope in than this short of the cecum means a
  // loop, whatever the loop index says (a straight scope reaches the cecum
  // with 0.7-0.8 m in, the mean with loops is 1.08 m; docs/scoring.md): it
  // reduces again once the tip is kLengthReduceAgainDepth_m deeper than at
  // the last reduction, and stops that reduction once the scope is
  // kLoopedLengthMargin_m under the limit: pulled much shorter, the model's
  // straightened scope stalls short of the cecum (docs/model-shortening-
  // notes.md, "The scope's length as a loop sign").
  static constexpr double kLoopedLength_m = 1.25;
  static constexpr double kLoopedLengthMargin_m = 0.10;
  static constexpr double kLengthReduceAgainDepth_m = 0.03;
  static constexpr double kMaxRoll_rad = 1.5;      // the hand turns the shaft at most this far
  static constexpr double kRollRelax_per_s = 0.3;  // and lets it untwist while advancing

  ExpertOperator(double dt_s, const Settings& settings) : dt_s_(dt_s), settings_(settings) {}
  explicit ExpertOperator(double dt_s) : ExpertOperator(dt_s, Settings{}) {}
  InputSample Act(const Perception& perception) override;

 private:
  // The steps of Act, in order. Not pulling back: start a reduction or a
  // back-off when a loop, a stall or the scope's length calls for one.
  void StartAPullBackIfNeeded(const Perception& perception, double loop_m);
  // Pulling back: stop once the loop is out or the pull is long enough.
  void EndThePullBackIfDone(const Perception& perception);
  // Turn a complaining patient back; the assistant lets go of the abdomen.
  void TendThePatient(const Perception& perception);
  // Knobs, shaft roll and the speed-tracking hand's force for this step.
  InputSample MoveTheHands(const Perception& perception);
  // A loop resisted a pull-back: the assistant presses over it or the
  // patient is turned (docs/scoring.md, "Calling for help").
  void CallForHelp(const Perception& perception);

  double dt_s_;
  Settings settings_;
  bool reducing_{false};
  bool backing_off_{false};  // the pull-back is a short back-off, not a reduction
  bool length_reduce_{false};  // the reduction was started by the scope's length alone
  bool started_{false};
  LoopIndex loop_index_;
  double last_reduce_tip_m_{-1.0};
  double last_stall_reduce_tip_m_{-1.0};  // tip at the last reduction for a stall
  double last_back_off_tip_m_{-1.0};      // and at the last back-off
  double stall_tip_m_{0.0};
  double stall_since_s_{0.0};
  double settle_until_s_{0.0};
  // The hand: its force and the scope's last position (for its speed).
  double hand_N_{0.0};
  double last_inserted_m_{0.0};
  // Reducing: when it started and the deepest tip since.
  double reduce_start_s_{0.0};
  double reduce_start_inserted_m_{0.0};
  double reduce_tip_max_m_{0.0};
  double reduce_start_loop_m_{0.0};
  double loose_tip_m_{-1.0};  // tip where the last pull-back found it loose
  // The assistant's hand and the patient's position.
  AbdominalPress press_{AbdominalPress::kNone};
  AbdominalPress pressed_before_{AbdominalPress::kNone};
  double press_until_tip_m_{0.0};
  double press_until_s_{0.0};
  PatientPosition position_{PatientPosition::kSupine};
  PatientPosition refused_position_{PatientPosition::kSupine};  // turned back from
  double complaint_since_s_{0.0};  // turned: since when the patient complains
  double knob_up_rad_{0.0};
  double knob_right_rad_{0.0};
  double roll_rad_{0.0};
};

// "novice" or "expert"; throws std::invalid_argument otherwise.
std::unique_ptr<ScriptedOperator> MakeScriptedOperator(std::string_view kind, double dt_s,
                                                       const ExpertOperator::Settings& expert);
std::unique_ptr<ScriptedOperator> MakeScriptedOperator(std::string_view kind, double dt_s);

}  // namespace ves::training
