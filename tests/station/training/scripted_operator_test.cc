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
// hooked tip does.
LengthRun AdvanceWithTheTip(double tip_into_fixed_colon_m) {
  ExpertOperator expert(kDt_s);
  Perception p;
  p.working_length_m = 1.68;
  p.tip_into_fixed_colon_m = tip_into_fixed_colon_m;
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

// Hooked in fixed colon with more scope in than a straight route needs, the
// expert takes the loop out though the loop index reads none, and stops once
// the scope is kLoopedLengthMargin_m under the limit (not after the 0.30 m
// a reduction may take).
TEST(ExpertOperator, ReducesWhenTheScopesLengthShowsALoop) {
  const LengthRun run = AdvanceWithTheTip(ExpertOperator::kHookDepth_m + 0.02);
  ASSERT_GT(run.reduce_started_at_m, 0.0) << "no reduction";
  // The hand turns from pushing to pulling within a centimetre or two.
  EXPECT_GT(run.reduce_started_at_m, ExpertOperator::kLoopedLength_m);
  EXPECT_LT(run.reduce_started_at_m, ExpertOperator::kLoopedLength_m + 0.02);
  ASSERT_GT(run.reduce_ended_at_m, 0.0) << "the reduction never ended";
  const double stop_m = ExpertOperator::kLoopedLength_m - ExpertOperator::kLoopedLengthMargin_m;
  EXPECT_LT(run.reduce_ended_at_m, stop_m);
  EXPECT_GT(run.reduce_ended_at_m, stop_m - 0.02);
}

// Not hooked (the tip in mobile colon) it does not pull back for the length:
// a tip that is not round a corner would come back with the scope.
TEST(ExpertOperator, DoesNotReduceForTheLengthUnhooked) {
  const LengthRun run = AdvanceWithTheTip(0.0);
  EXPECT_LT(run.reduce_started_at_m, 0.0) << "reduced at " << run.reduce_started_at_m << " m in";
}

// A scope that does not move however hard it is pushed (the tip in mobile
// colon, so no stall in fixed colon calls for a pull-back): the hand's force
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
    for (int step = 0; step < 20000; ++step) {
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
