// The scripted expert's decisions on perceptions made by hand (docs/scoring.md,
// "Scripted operators"); the whole-colon runs are in scripted_session_test.cc.
#include <gtest/gtest.h>

#include <algorithm>

#include "station/training/scripted_operator.h"

namespace ves::training {
namespace {

constexpr double kDt_s = 1e-3;
// The scope moves at the hand's force over this drag (a hand that wants
// 1 cm/s pushes 4 N), so the hand's own speed loop settles.
constexpr double kDrag_N_s_per_m = 400.0;

struct LengthRun {
  double reduce_started_at_m{-1.0};  // scope in when the hand first pulled
  double reduce_ended_at_m{-1.0};    // and when it pushed again
};

// The scope advances with the tip one to one (no loop the loop index could
// see) from 1.10 m in; pulled, the scope comes out and the tip holds, as a
// tip anchored beyond a loop does.
LengthRun AdvanceWithTheTip() {
  ExpertOperator expert(kDt_s);
  Perception p;
  p.working_length_m = 1.68;
  double inserted_m = 1.10, tip_m = 1.50;
  LengthRun run;
  for (int step = 0; step < 120000 && inserted_m < 1.50; ++step) {
    p.t_s = step * kDt_s;
    p.inserted_m = inserted_m;
    p.tip_arc_m = tip_m;
    const InputSample in = expert.Act(p);
    if (in.push_force_N < 0.0 && run.reduce_started_at_m < 0.0) run.reduce_started_at_m = inserted_m;
    if (in.push_force_N > 0.0 && run.reduce_started_at_m >= 0.0) {
      run.reduce_ended_at_m = inserted_m;
      break;
    }
    const double move_m = in.push_force_N / kDrag_N_s_per_m * kDt_s;
    inserted_m += move_m;
    if (move_m > 0.0) tip_m += move_m;
  }
  return run;
}

// With more scope in than a straight route needs, the expert takes the loop
// out though the loop index reads none, and stops once the scope is
// kLoopedLengthMargin_m under the limit (not after the 0.30 m a reduction
// may take).
TEST(ExpertOperator, ReducesWhenTheScopesLengthShowsALoop) {
  const LengthRun run = AdvanceWithTheTip();
  ASSERT_GT(run.reduce_started_at_m, 0.0) << "no reduction";
  // The hand turns from pushing to pulling within a centimetre or two.
  EXPECT_GT(run.reduce_started_at_m, ExpertOperator::kLoopedLength_m);
  EXPECT_LT(run.reduce_started_at_m, ExpertOperator::kLoopedLength_m + 0.02);
  ASSERT_GT(run.reduce_ended_at_m, 0.0) << "the reduction never ended";
  const double stop_m = ExpertOperator::kLoopedLength_m - ExpertOperator::kLoopedLengthMargin_m;
  EXPECT_LT(run.reduce_ended_at_m, stop_m);
  EXPECT_GT(run.reduce_ended_at_m, stop_m - 0.02);
}

// What the expert did with a loop whose tip is loose: the tip advances one to
// one for 5 cm, then stops while the scope goes on (a loop forms); pulled, the
// tip comes back with the scope.
struct LooseLoopRun {
  int pull_backs{0};
  double longest_pull_m{0.0};  // scope withdrawn in one pull-back
  AbdominalPress first_press{AbdominalPress::kNone};
  double pressed_at_tip_m{-1.0};
  PatientPosition last_position{PatientPosition::kSupine};
};

LooseLoopRun PushALooseLoop(double start_tip_m, double seconds) {
  ExpertOperator expert(kDt_s);
  Perception p;
  p.working_length_m = 1.68;
  const double start_inserted_m = start_tip_m + 0.05;
  double inserted_m = start_inserted_m, tip_m = start_tip_m;
  double pull_from_m = -1.0;
  LooseLoopRun run;
  for (int step = 0; step < seconds / kDt_s; ++step) {
    p.t_s = step * kDt_s;
    p.inserted_m = inserted_m;
    p.tip_arc_m = tip_m;
    const InputSample in = expert.Act(p);
    if (in.push_force_N < 0.0 && pull_from_m < 0.0) {
      pull_from_m = inserted_m;
      ++run.pull_backs;
    }
    if (in.push_force_N > 0.0 && pull_from_m >= 0.0) {
      run.longest_pull_m = std::max(run.longest_pull_m, pull_from_m - inserted_m);
      pull_from_m = -1.0;
    }
    if (in.abdominal_press != AbdominalPress::kNone && run.first_press == AbdominalPress::kNone) {
      run.first_press = in.abdominal_press;
      run.pressed_at_tip_m = tip_m;
    }
    run.last_position = in.patient_position;
    const double move_m = in.push_force_N / kDrag_N_s_per_m * kDt_s;
    inserted_m += move_m;
    // The tip follows the scope out, and in only for the first 5 cm.
    if (move_m < 0.0 || inserted_m < start_inserted_m + 0.05) tip_m += move_m;
  }
  return run;
}

// The tip comes back with the scope: the pull-back ends within a few
// centimetres, and a loop that resists it makes the expert ask the assistant
// to press over it: the left lower quadrant with the tip short of
// kSigmoidTip_m, mid-abdomen beyond. When the loop resists again the patient
// is turned.
TEST(ExpertOperator, AsksForThePressWhereALoopResistsAPullBack) {
  const LooseLoopRun sigmoid = PushALooseLoop(0.40, 120.0);
  ASSERT_GE(sigmoid.pull_backs, 1);
  EXPECT_LT(sigmoid.longest_pull_m, ExpertOperator::kLoosePull_m + ExpertOperator::kTipBack_m + 0.005);
  EXPECT_EQ(sigmoid.first_press, AbdominalPress::kLeftLowerQuadrant);
  const LooseLoopRun transverse = PushALooseLoop(1.00, 120.0);
  EXPECT_EQ(transverse.first_press, AbdominalPress::kMidAbdomen);
  ASSERT_GE(sigmoid.pull_backs, 2) << "the loop never resisted twice";
  EXPECT_NE(sigmoid.last_position, PatientPosition::kSupine);
}

// A tip stalled while the patient complains: in the sigmoid (short of
// kSigmoidTip_m) a loop holds it back, and after kStall_s the expert asks the
// assistant to press the left lower quadrant; stalled in pain beyond, it
// neither pulls back nor calls for help.
TEST(ExpertOperator, AsksForThePressWhenTheTipStallsInTheSigmoidWhileThePatientComplains) {
  auto stall_in_pain = [](double tip_m, AbdominalPress* press, PatientPosition* position,
                          double* least_push_N) {
    ExpertOperator expert(kDt_s);
    Perception p;
    p.working_length_m = 1.68;
    p.inserted_m = tip_m + 0.12;
    p.tip_arc_m = tip_m;
    p.peak_stretch_m = 0.04;
    *press = AbdominalPress::kNone;
    *position = PatientPosition::kSupine;
    *least_push_N = 1e9;
    for (int step = 0; step < static_cast<int>((ExpertOperator::kStall_s + 5.0) / kDt_s); ++step) {
      p.t_s = step * kDt_s;
      const InputSample in = expert.Act(p);
      if (in.abdominal_press != AbdominalPress::kNone) *press = in.abdominal_press;
      if (in.patient_position != PatientPosition::kSupine) *position = in.patient_position;
      if (p.t_s > 2.0) *least_push_N = std::min(*least_push_N, in.push_force_N);
    }
  };
  AbdominalPress press;
  PatientPosition position;
  double least_push_N = 0.0;
  stall_in_pain(0.45, &press, &position, &least_push_N);
  EXPECT_EQ(press, AbdominalPress::kLeftLowerQuadrant);
  EXPECT_GT(least_push_N, 0.0) << "it pulled back";
  stall_in_pain(1.00, &press, &position, &least_push_N);
  EXPECT_EQ(press, AbdominalPress::kNone);
  EXPECT_EQ(position, PatientPosition::kSupine);
  EXPECT_GT(least_push_N, 0.0) << "it pulled back";
}

// A scope that does not move however hard it is pushed (for less than the
// stall that calls for a pull-back): the hand's force
// rises toward the speed it wants until its limit, 10 N by default (the level
// real hands stay under 95 % of the time, docs/scoring.md), and no further.
TEST(ExpertOperator, PushesAStuckScopeUpToItsLimitAndNoFurther) {
  for (const double limit_N : {ExpertOperator::Settings{}.push_limit_N, 6.4}) {
    ExpertOperator::Settings settings;
    settings.push_limit_N = limit_N;
    ExpertOperator expert(kDt_s, settings);
    Perception p;
    p.working_length_m = 1.68;
    p.inserted_m = 0.50;
    p.tip_arc_m = 0.45;
    double peak_N = 0.0, last_N = 0.0;
    for (int step = 0; step < 14000; ++step) {
      p.t_s = step * kDt_s;
      const InputSample in = expert.Act(p);
      ASSERT_GE(in.push_force_N, 0.0) << "pulled at " << p.t_s << " s";
      peak_N = std::max(peak_N, in.push_force_N);
      last_N = in.push_force_N;
    }
    EXPECT_DOUBLE_EQ(peak_N, limit_N);
    EXPECT_DOUBLE_EQ(last_N, limit_N);
  }
  EXPECT_DOUBLE_EQ(ExpertOperator::Settings{}.push_limit_N, 10.0);
}

}  // namespace
}  // namespace ves::training
