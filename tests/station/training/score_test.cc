#include "station/training/score.h"

#include <gtest/gtest.h>

namespace ves::training {
namespace {

constexpr double kTolerance = 1e-9;
constexpr double kCecumArc_m = 1.5;  // t_half = 1.5 / 0.01 = 150 s with the defaults

Metrics Completed(double time_s) {
  Metrics m;
  m.completed = true;
  m.time_to_cecum_s = time_s;
  m.duration_s = time_s;
  m.max_tip_arc_m = kCecumArc_m;
  return m;
}

TEST(Score, CompletedAtTheHalfTimeOnAnEasyCaseIs75) {
  // time component 1 / (1 + 150 / 150) = 0.5; easy weights time only: 50 + 50 * 0.5.
  EXPECT_NEAR(CalcScore(Completed(150.0), v1::DIFFICULTY_EASY, kCecumArc_m), 75.0, kTolerance);
}

TEST(Score, EasyCasesSeparateOnlyByTime) {
  Metrics clean = Completed(100.0);
  Metrics rough = clean;
  rough.pain_s = 40.0;
  rough.loop_s = 60.0;
  rough.excessive_force_s = 10.0;
  rough.xray_s = 100.0;
  EXPECT_EQ(CalcScore(clean, v1::DIFFICULTY_EASY, kCecumArc_m),
            CalcScore(rough, v1::DIFFICULTY_EASY, kCecumArc_m));
  EXPECT_GT(CalcScore(Completed(90.0), v1::DIFFICULTY_EASY, kCecumArc_m),
            CalcScore(Completed(100.0), v1::DIFFICULTY_EASY, kCecumArc_m));
}

TEST(Score, HardCasesAlsoPenalisePainLoopsForceAndXray) {
  const Metrics clean = Completed(100.0);
  const double base = CalcScore(clean, v1::DIFFICULTY_HARD, kCecumArc_m);
  for (int which = 0; which < 4; ++which) {
    Metrics rough = clean;
    if (which == 0) rough.pain_s = 10.0;
    if (which == 1) rough.loop_s = 10.0;
    if (which == 2) rough.excessive_force_s = 10.0;
    if (which == 3) rough.xray_s = 50.0;
    EXPECT_LT(CalcScore(rough, v1::DIFFICULTY_HARD, kCecumArc_m), base) << "component " << which;
  }
}

TEST(Score, HardCaseComponentsCombineWithTheDocumentedWeights) {
  // time 150 s -> 0.5; pain 10 s -> 0.5; loop 20 s -> 0.5; force 0 -> 1;
  // xray 75 of 150 s -> 0.5. Hard: 0.25*0.5 + 0.25*0.5 + 0.2*0.5 + 0.15*1 + 0.15*0.5
  // = 0.575; score 50 + 50 * 0.575 = 78.75.
  Metrics m = Completed(150.0);
  m.pain_s = 10.0;
  m.loop_s = 20.0;
  m.xray_s = 75.0;
  EXPECT_NEAR(CalcScore(m, v1::DIFFICULTY_HARD, kCecumArc_m), 78.75, kTolerance);
}

TEST(Score, IncompleteRunsScoreByProgressAndAtMostHalf) {
  // Easy, tip at half the cecum arc: 50 * 0.5 * 1 = 25.
  Metrics m;
  m.duration_s = 600.0;
  m.max_tip_arc_m = 0.75;
  EXPECT_NEAR(CalcScore(m, v1::DIFFICULTY_EASY, kCecumArc_m), 25.0, kTolerance);
  m.max_tip_arc_m = 1.49;
  EXPECT_LT(CalcScore(m, v1::DIFFICULTY_HARD, kCecumArc_m), 50.0);
}

TEST(Score, EachDamageEventCostsTenPointsDownToZero) {
  Metrics m = Completed(0.0);
  EXPECT_NEAR(CalcScore(m, v1::DIFFICULTY_MEDIUM, kCecumArc_m), 100.0, kTolerance);
  m.damage_events = 2;
  EXPECT_NEAR(CalcScore(m, v1::DIFFICULTY_MEDIUM, kCecumArc_m), 80.0, kTolerance);
  m.damage_events = 20;
  EXPECT_EQ(CalcScore(m, v1::DIFFICULTY_MEDIUM, kCecumArc_m), 0.0);
}

TEST(Score, WeightsOfEveryDifficultySumToOne) {
  const ScoreParams p;
  for (const ScoreWeights& w : {p.easy, p.medium, p.hard}) {
    EXPECT_NEAR(w.time + w.pain + w.loop + w.force + w.xray, 1.0, kTolerance);
  }
}

TEST(Score, NonPositiveCecumArcIsRefused) {
  EXPECT_THROW(CalcScore(Metrics{}, v1::DIFFICULTY_EASY, 0.0), std::invalid_argument);
}

}  // namespace
}  // namespace ves::training
