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
};

// How far ahead of the tip the image shows the lumen: the deformed centerline
// at this arc beyond the tip.
inline constexpr double kLumenLookahead_m = 0.04;

Perception Perceive(const model::ModelParams& params, const model::ModelState& state,
                    const model::StepOutput& output, double lumen_lookahead_m = kLumenLookahead_m);

// A scripted trainee: produces the same InputSample a person's hands produce
// (for tests, demos and calibration, docs/scoring.md). Deterministic.
class ScriptedOperator {
 public:
  virtual ~ScriptedOperator() = default;
  virtual InputSample Act(const Perception& perception) = 0;
};

// Pushes with a steady force, leaves the knobs alone (ignores the lumen),
// watches the fluoroscopy all the time and uses the wireframe view.
class NoviceOperator final : public ScriptedOperator {
 public:
  static constexpr double kPushForce_N = 6.0;
  InputSample Act(const Perception& perception) override;
};

// Steers the tip toward the lumen with the knobs. It starts by pushing
// through firmly (the mobile sigmoid can only be passed by bowing it), then,
// for good once the loop has taken 20 cm of scope or the patient has hurt for
// 10 s, works gently: when a loop builds (the scope goes in but the image does
// not advance), the hand force rises, the patient complains of stretch, or the
// tip stops advancing, it pulls back while torquing and relaxing the tip, then
// advances again. It stops pulling once the scope is shorter than the path to
// its tip (more would only drag the colon), and torques instead of pulling
// when it stalls with no slack to take out. Fluoroscopy off, textured view.
// docs/scoring.md, "Scripted operators".
class ExpertOperator final : public ScriptedOperator {
 public:
  // How hard a technique pushes and what makes it pull back: the hand force,
  // the stretch (the patient complains) or the loop index passing these.
  struct Technique {
    double push_N;
    double force_limit_N;
    double complaint_stretch_m;
    double loop_start_m;
  };
  static constexpr Technique kGentle{
      .push_N = 4.0, .force_limit_N = 6.0, .complaint_stretch_m = 0.025, .loop_start_m = 0.04};
  static constexpr Technique kPushThrough{
      .push_N = 9.0, .force_limit_N = 12.0, .complaint_stretch_m = 0.08, .loop_start_m = 0.30};
  // Pushing through ends for good at this much scope in a loop (inserted
  // length minus the tip's arc) or this much pain.
  static constexpr double kPushThroughSlackLimit_m = 0.20;
  static constexpr double kPushThroughPainLimit_s = 10.0;
  // The stretch the patient calls pain: the metrics' pain level.
  static constexpr double kPainStretch_m = MetricThresholds{}.pain_stretch_m;

  static constexpr double kPullForce_N = -1.5;
  static constexpr double kSteerGain_per_s = 8.0;  // knob angle rate per radian of lumen offset
  static constexpr double kLoopDone_m = 0.01;
  static constexpr double kRollRate_rad_per_s = 1.0;
  static constexpr double kStallWindow_s = 1.5;  // no advance over this long is a stall
  static constexpr double kStallAdvance_m = 0.003;
  static constexpr double kWithdraw_s = 0.6;       // shortest pull-back
  static constexpr double kWithdrawMax_s = 2.0;    // longest pull-back
  static constexpr double kKnobRelax_per_s = 2.0;  // knobs ease toward neutral while pulling
  // Slack below which a pull-back ends: the scope is already shorter than
  // the path to its tip.
  static constexpr double kStraightSlack_m = -0.02;
  // Gentle: a stall with less slack than this is torqued through, not pulled back.
  static constexpr double kTorqueSlack_m = 0.03;
  static constexpr double kTorque_s = 1.5;
  // During a pull-back with less slack than this the hand relaxes (0 N).
  static constexpr double kRelaxHandSlack_m = 0.02;

  explicit ExpertOperator(double dt_s) : dt_s_(dt_s) {}
  InputSample Act(const Perception& perception) override;

 private:
  double dt_s_;
  LoopIndex loop_index_;
  bool pushing_through_{true};
  double pain_s_{0.0};
  bool withdrawing_{false};
  double phase_start_s_{0.0};
  double loop_at_start_m_{0.0};
  double window_start_s_{0.0};
  double window_arc_m_{0.0};
  double torque_until_s_{-1.0};
  double roll_direction_{1.0};
  double knob_up_rad_{0.0};
  double knob_right_rad_{0.0};
  double roll_rad_{0.0};
};

// "novice" or "expert"; throws std::invalid_argument otherwise.
std::unique_ptr<ScriptedOperator> MakeScriptedOperator(std::string_view kind, double dt_s);

}  // namespace ves::training
