#include "station/training/metrics.h"

#include "station/training/session.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <utility>
#include <vector>

namespace ves::training {
namespace {

// Steps of 0.25 s and lengths in 1/64 m are exact in binary: the expected
// values below are exact sums, compared with EXPECT_EQ unless noted.
constexpr double kDt_s = 0.25;
constexpr double kTolerance = 1e-12;

std::vector<StepObservation> Steps(int n) {
  std::vector<StepObservation> steps(n);
  for (int i = 0; i < n; ++i) {
    steps[i].t_s = (i + 1) * kDt_s;
    steps[i].dt_s = kDt_s;
  }
  return steps;
}

MetricThresholds Thresholds() {
  MetricThresholds t;
  t.cecum_arc_m = 1.0;
  t.excessive_wall_force_N = 4.0;
  t.damage_wall_force_N = 8.0;
  t.pain_stretch_m = 0.03;
  t.loop_enter_m = 4.0 / 64.0;
  t.loop_exit_m = 2.0 / 64.0;
  t.redout_fraction = 0.5;
  t.episode_merge_gap_s = 0.2;  // one 0.25 s step apart is already two episodes
  return t;
}

MetricsAccumulator Accumulate(const std::vector<StepObservation>& steps,
                              const MetricThresholds& thresholds = Thresholds()) {
  MetricsAccumulator acc(thresholds);
  for (const auto& s : steps) acc.Add(s);
  return acc;
}

int CountEvents(const MetricsAccumulator& acc, EventKind kind) {
  const auto events = acc.Events();
  return static_cast<int>(std::count_if(events.begin(), events.end(),
                                        [kind](const Event& e) { return e.kind == kind; }));
}

TEST(Metrics, TimeToCecumIsTheFirstStepWhoseTipArcReachesTheCecum) {
  // tip arc = (i+1)/8 m reaches 1.0 m at i = 7, t = 8 * 0.25 = 2.0 s.
  auto steps = Steps(12);
  for (int i = 0; i < 12; ++i) steps[i].tip_arc_m = (i + 1) / 8.0;
  const auto acc = Accumulate(steps);
  const Metrics m = acc.Result();
  EXPECT_TRUE(m.completed);
  EXPECT_EQ(m.time_to_cecum_s, 2.0);
  EXPECT_EQ(m.duration_s, 3.0);
  EXPECT_EQ(m.max_tip_arc_m, 1.5);
  EXPECT_EQ(CountEvents(acc, EventKind::kCecumReached), 1);
}

TEST(Metrics, NotReachingTheCecumLeavesTimeToCecumZero) {
  auto steps = Steps(4);
  for (auto& s : steps) {
    s.tip_arc_m = 0.9;
    s.inserted_m = 1.25;
  }
  const Metrics m = Accumulate(steps).Result();
  EXPECT_FALSE(m.completed);
  EXPECT_EQ(m.time_to_cecum_s, 0.0);
  EXPECT_EQ(m.inserted_at_cecum_m, 0.0);
}

TEST(Metrics, InsertedLengthAtTheCecumIsTakenWhenItIsFirstReached) {
  // The scope is pushed in 1/4 m a step and the tip reaches the cecum (1 m)
  // at step 6 with 1.75 m inserted (a loop); later steps push further and
  // pull back, which must not change the figure.
  auto steps = Steps(10);
  for (int i = 0; i < 10; ++i) {
    steps[i].inserted_m = 0.25 * (i + 1);
    steps[i].tip_arc_m = i < 6 ? 0.125 * (i + 1) : 1.0 + 0.0625 * (i % 2);
  }
  steps[9].inserted_m = 1.0;  // withdrawn (the loop reduced)
  const Metrics m = Accumulate(steps).Result();
  ASSERT_TRUE(m.completed);
  EXPECT_EQ(m.time_to_cecum_s, 7 * kDt_s);
  EXPECT_EQ(m.inserted_at_cecum_m, 1.75);
  EXPECT_EQ(FromProto(ToProto(m)).inserted_at_cecum_m, 1.75);
}

TEST(Metrics, PeakAndMeanInsertionForceUseTheMagnitude) {
  // |F| = 1, 3, 2, 2: peak 3, time mean (1 + 3 + 2 + 2) / 4 = 2.
  auto steps = Steps(4);
  const double forces[] = {1.0, -3.0, 2.0, 2.0};
  for (int i = 0; i < 4; ++i) steps[i].base_force_N = forces[i];
  const Metrics m = Accumulate(steps).Result();
  EXPECT_EQ(m.peak_insertion_force_N, 3.0);
  EXPECT_EQ(m.mean_insertion_force_N, 2.0);
}

TEST(Metrics, PeakInsertionForceIsTakenOverTenMillisecondsAtTheModelRate) {
  // At 1 ms steps: a 1-step transient of 101 N on a 1 N background averages
  // to (9 * 1 + 101) / 10 = 11 N over the 10 ms window; a force held for
  // 10 steps is its own 10 ms mean (6 N). The mean keeps every step.
  constexpr double kModelDt_s = 0.001;
  constexpr int kSteps = 60;
  std::vector<StepObservation> steps(kSteps);
  for (int i = 0; i < kSteps; ++i) {
    steps[i].t_s = (i + 1) * kModelDt_s;
    steps[i].dt_s = kModelDt_s;
    steps[i].base_force_N = 1.0;
  }
  steps[20].base_force_N = 101.0;
  const Metrics spike = Accumulate(steps).Result();
  EXPECT_NEAR(spike.peak_insertion_force_N, 11.0, 1e-9);
  EXPECT_NEAR(spike.mean_insertion_force_N, (59.0 + 101.0) / 60.0, 1e-9);

  steps[20].base_force_N = 1.0;
  for (int i = 40; i < 50; ++i) steps[i].base_force_N = -6.0;
  EXPECT_NEAR(Accumulate(steps).Result().peak_insertion_force_N, 6.0, 1e-9);
}

TEST(Metrics, ExcessiveForceEpisodesCountRunsOverTheThreshold) {
  // Over 4 N at steps 0-1 and 5-7: two episodes, 5 steps = 1.25 s.
  auto steps = Steps(9);
  const double wall[] = {5, 5, 0, 0, 0, 6, 6, 6, 1};
  for (int i = 0; i < 9; ++i) steps[i].max_wall_force_N = wall[i];
  const auto acc = Accumulate(steps);
  const Metrics m = acc.Result();
  EXPECT_EQ(m.excessive_force_episodes, 2u);
  EXPECT_EQ(m.excessive_force_s, 1.25);
  EXPECT_EQ(CountEvents(acc, EventKind::kExcessiveForce), 2);
  EXPECT_EQ(m.damage_events, 0u);  // never over 8 N
}

TEST(Metrics, ForceExactlyAtTheThresholdIsNotExcessive) {
  auto steps = Steps(3);
  for (auto& s : steps) s.max_wall_force_N = 4.0;
  EXPECT_EQ(Accumulate(steps).Result().excessive_force_episodes, 0u);
}

TEST(Metrics, PainIsTimeWithMesenteryStretchOverThePainThreshold) {
  // Stretch over 0.03 m at 3 of 5 steps: 0.75 s; peak 0.06 m.
  auto steps = Steps(5);
  const double stretch[] = {0.01, 0.04, 0.05, 0.02, 0.06};
  for (int i = 0; i < 5; ++i) steps[i].peak_stretch_m = stretch[i];
  const auto acc = Accumulate(steps);
  const Metrics m = acc.Result();
  EXPECT_EQ(m.pain_s, 0.75);
  EXPECT_EQ(m.peak_stretch_m, 0.06);
  EXPECT_EQ(CountEvents(acc, EventKind::kPain), 2);  // steps 1-2 and step 4
}

// Slack (inserted - tip arc) in 1/64 m per step; the tip stays at 0.5 m.
std::vector<StepObservation> SlackSteps(const std::vector<int>& slack_64ths) {
  auto steps = Steps(static_cast<int>(slack_64ths.size()));
  for (std::size_t i = 0; i < steps.size(); ++i) {
    steps[i].tip_arc_m = 0.5;
    steps[i].inserted_m = 0.5 + slack_64ths[i] / 64.0;
  }
  return steps;
}

TEST(Metrics, LoopIsSlackGrowingOverTheEnterThresholdWithHysteresis) {
  // Slack 0,0,0,0,1,2,3,4,5,6,5,4,3,2,1,0 | 4,1 (1/64 m). Enter at >= 4,
  // leave below 2: first loop from position 7 to 13 (7 steps), second loop
  // position 16 only (1 step): 2 loops, 8 * 0.25 = 2.0 s.
  const auto acc = Accumulate(SlackSteps({0, 0, 0, 0, 1, 2, 3, 4, 5, 6, 5, 4, 3, 2, 1, 0, 4, 1}));
  const Metrics m = acc.Result();
  EXPECT_EQ(m.loop_count, 2u);
  EXPECT_EQ(m.loop_s, 2.0);
  const auto events = acc.Events();
  const auto first = std::find_if(events.begin(), events.end(),
                                  [](const Event& e) { return e.kind == EventKind::kLoop; });
  ASSERT_NE(first, events.end());
  EXPECT_EQ(first->t_s, 1.75);          // start of step 7
  EXPECT_EQ(first->value, 6.0 / 64.0);  // peak loop index
}

TEST(Metrics, LoopIndexIsMeasuredFromTheLowestSlackSoFar) {
  // A scope cutting a corner has negative slack (-10/64 m); a later rise of
  // 3/64 stays under the 4/64 threshold, a rise of 5/64 is a loop.
  const Metrics below = Accumulate(SlackSteps({0, -10, -10, -7, -7})).Result();
  EXPECT_EQ(below.loop_count, 0u);
  const Metrics above = Accumulate(SlackSteps({0, -10, -10, -5, -5})).Result();
  EXPECT_EQ(above.loop_count, 1u);
  EXPECT_EQ(above.loop_s, 0.5);
}

// (inserted, tip arc) in 1/64 m per step.
std::vector<StepObservation> ScopeSteps(
    const std::vector<std::pair<int, int>>& inserted_tip_64ths) {
  auto steps = Steps(static_cast<int>(inserted_tip_64ths.size()));
  for (std::size_t i = 0; i < steps.size(); ++i) {
    steps[i].inserted_m = inserted_tip_64ths[i].first / 64.0;
    steps[i].tip_arc_m = inserted_tip_64ths[i].second / 64.0;
  }
  return steps;
}

TEST(Metrics, AScopePulledOutAfterADeepReductionIsNotInALoop) {
  // In to 40/64 m with the tip, then withdrawn 10/64 while the hooked tip
  // holds at 40 (slack -10: the colon straightened onto the scope), then the
  // tip slips back and the scope comes out. Measured from the lowest slack
  // ever (-10), the last steps would read as a 10/64 m loop with no scope in
  // the patient; measured at each depth, they are not a loop.
  const auto acc = Accumulate(ScopeSteps({{10, 10},
                                          {20, 20},
                                          {30, 30},
                                          {40, 40},
                                          {35, 40},
                                          {30, 40},
                                          {25, 24},
                                          {10, 10},
                                          {0, 0},
                                          {0, 0}}));
  EXPECT_EQ(acc.Result().loop_count, 0u);
  EXPECT_EQ(acc.loop_index_m(), 0.0);
}

TEST(Metrics, PushingBackAfterAReductionAtTheSameDepthIsALoop) {
  // The same reduction, then the scope pushed 6/64 m back in while the tip
  // stays at 40: the sigmoid bows again, a loop of 6/64 m.
  const auto acc = Accumulate(
      ScopeSteps({{10, 10}, {20, 20}, {30, 30}, {40, 40}, {30, 40}, {33, 40}, {36, 40}}));
  EXPECT_EQ(acc.Result().loop_count, 1u);
  EXPECT_EQ(acc.loop_index_m(), 6.0 / 64.0);
}

TEST(Metrics, AdvancingTipWithTheScopeMakesNoLoop) {
  auto steps = Steps(20);
  for (int i = 0; i < 20; ++i) steps[i].inserted_m = steps[i].tip_arc_m = i / 16.0;
  const auto acc = Accumulate(steps);
  EXPECT_EQ(acc.Result().loop_s, 0.0);
  EXPECT_EQ(acc.loop_index_m(), 0.0);
}

TEST(Metrics, RedoutTimeCountsStepsAtOrOverTheRedFraction) {
  auto steps = Steps(5);
  const double red[] = {0.2, 0.6, 0.5, 0.4, 1.0};
  for (int i = 0; i < 5; ++i) steps[i].redout_fraction = red[i];
  EXPECT_EQ(Accumulate(steps).Result().redout_s, 0.75);
}

TEST(Metrics, MucosaSeenIsTheLargestCoverageReported) {
  auto steps = Steps(3);
  const double seen[] = {0.1, 0.3, 0.25};
  for (int i = 0; i < 3; ++i) steps[i].mucosa_seen_fraction = seen[i];
  EXPECT_EQ(Accumulate(steps).Result().mucosa_seen_fraction, 0.3);
}

TEST(Metrics, XrayTimeIsFluoroscopyOnTime) {
  // On at steps 1-3 and 6-7: 5 steps = 1.25 s; toggles: on, off, on.
  auto steps = Steps(8);
  const int on[] = {0, 1, 1, 1, 0, 0, 1, 1};
  for (int i = 0; i < 8; ++i) steps[i].fluoroscopy_on = on[i] != 0;
  const auto acc = Accumulate(steps);
  EXPECT_EQ(acc.Result().xray_s, 1.25);
  EXPECT_EQ(CountEvents(acc, EventKind::kFluoroscopy), 3);
}

TEST(Metrics, ViewModeSwitchesAreEvents) {
  auto steps = Steps(4);
  steps[0].view_mode = ViewMode::kTextured;
  steps[1].view_mode = ViewMode::kWireframe;
  steps[2].view_mode = ViewMode::kWireframe;
  steps[3].view_mode = ViewMode::kFlat;
  EXPECT_EQ(CountEvents(Accumulate(steps), EventKind::kViewMode), 2);
}

TEST(Metrics, ToolkitTimesArePerSiteAndPositionAndTurnsAreCountedFromSupine) {
  // Press: none, LLQ, LLQ, mid, none, LLQ, none, none -> LLQ 0.75 s, mid 0.25 s.
  // Position: left, left, supine, right, right, right, supine, supine -> left
  // 0.5 s, right 0.75 s; turns: to left (from the supine start), to supine,
  // to right, to supine = 4.
  auto steps = Steps(8);
  using P = AbdominalPress;
  using Q = PatientPosition;
  const P press[] = {P::kNone, P::kLeftLowerQuadrant, P::kLeftLowerQuadrant, P::kMidAbdomen,
                     P::kNone, P::kLeftLowerQuadrant, P::kNone,              P::kNone};
  const Q position[] = {Q::kLeftLateral,  Q::kLeftLateral,  Q::kSupine, Q::kRightLateral,
                        Q::kRightLateral, Q::kRightLateral, Q::kSupine, Q::kSupine};
  for (int i = 0; i < 8; ++i) {
    steps[i].abdominal_press = press[i];
    steps[i].patient_position = position[i];
  }
  const Metrics m = Accumulate(steps).Result();
  EXPECT_EQ(m.press_llq_s, 0.75);
  EXPECT_EQ(m.press_mid_s, 0.25);
  EXPECT_EQ(m.left_lateral_s, 0.5);
  EXPECT_EQ(m.right_lateral_s, 0.75);
  EXPECT_EQ(m.position_changes, 4u);
  // Through the record's proto and back.
  EXPECT_EQ(FromProto(ToProto(m)), m);
  // A session that never used them records zeros.
  const Metrics plain = Accumulate(Steps(8)).Result();
  EXPECT_EQ(plain.press_llq_s + plain.press_mid_s + plain.left_lateral_s + plain.right_lateral_s,
            0.0);
  EXPECT_EQ(plain.position_changes, 0u);
}

TEST(Metrics, TipPathIsTheSumOfTipDisplacements) {
  // (0,0,0) -> (0.03,0.04,0) -> (0.03,0.04,0.12): 0.05 + 0.12 = 0.17 m.
  auto steps = Steps(3);
  steps[1].p_WTip = Eigen::Vector3d(0.03, 0.04, 0.0);
  steps[2].p_WTip = Eigen::Vector3d(0.03, 0.04, 0.12);
  EXPECT_NEAR(Accumulate(steps).Result().tip_path_m, 0.17, kTolerance);
}

TEST(Metrics, DamageEventsRecordWhereAndHowMuch) {
  // Wall force 9, 10, 3, 12 N over the 8 N damage threshold: episodes at
  // steps 0-1 (impulse (1 + 2) * 0.25 = 0.75 N·s at the 10 N peak, arc 0.2 m)
  // and step 3 (4 * 0.25 = 1.0 N·s): 2 events, 1.75 N·s.
  auto steps = Steps(4);
  const double wall[] = {9, 10, 3, 12};
  const double arc[] = {0.1, 0.2, 0.3, 0.4};
  for (int i = 0; i < 4; ++i) {
    steps[i].max_wall_force_N = wall[i];
    steps[i].max_wall_force_arc_m = arc[i];
  }
  const auto acc = Accumulate(steps);
  const Metrics m = acc.Result();
  EXPECT_EQ(m.damage_events, 2u);
  EXPECT_EQ(m.damage_impulse_N_s, 1.75);
  std::vector<Event> damage;
  for (const Event& e : acc.Events()) {
    if (e.kind == EventKind::kDamage) damage.push_back(e);
  }
  ASSERT_EQ(damage.size(), 2u);
  EXPECT_EQ(damage[0].arc_m, 0.2);
  EXPECT_EQ(damage[0].value, 0.75);
  EXPECT_EQ(damage[1].arc_m, 0.4);
  EXPECT_EQ(damage[1].value, 1.0);
}

TEST(Metrics, DamageMapAccumulatesPerSegmentImpulse) {
  // Segment 1 at 10 N for 2 steps: (10 - 8) * 0.25 * 2 = 1.0 N·s; others under.
  const std::vector<double> forces = {1.0, 10.0, 7.9};
  const std::vector<double> arcs = {0.1, 0.2, 0.3};
  auto steps = Steps(2);
  for (auto& s : steps) {
    s.segment_wall_force_N = forces;
    s.segment_arc_m = arcs;
    s.max_wall_force_N = 10.0;
  }
  const auto acc = Accumulate(steps);
  ASSERT_EQ(acc.damage_map_N_s().size(), 3u);
  EXPECT_EQ(acc.damage_map_N_s()[0], 0.0);
  EXPECT_EQ(acc.damage_map_N_s()[1], 1.0);
  EXPECT_EQ(acc.damage_map_N_s()[2], 0.0);
}

// At 1 ms steps a wall force counts as damage once its 10 ms mean is over
// the threshold: the model's contact transients of 1-3 steps (a sample
// changing segment at a sharp fold, docs/model.md "Known limits") do not,
// a press held for 20 ms does, and the map marks only the pressed segment.
TEST(Metrics, DamageNeedsTheWallForceHeldOverTheForceWindow) {
  constexpr int kSteps = 400;  // the two are further apart than the 0.2 s merge gap
  const std::vector<double> quiet = {1.0, 1.0}, spike = {20.0, 1.0}, press = {1.0, 12.0};
  const std::vector<double> arcs = {0.1, 0.2};
  std::vector<StepObservation> steps(kSteps);
  for (int i = 0; i < kSteps; ++i) {
    steps[i].t_s = (i + 1) * 0.001;
    steps[i].dt_s = 0.001;
    steps[i].max_wall_force_N = 1.0;
    steps[i].segment_wall_force_N = quiet;
    steps[i].segment_arc_m = arcs;
  }
  for (int i = 20; i < 23; ++i) {  // a 3 ms spike to 20 N on segment 0
    steps[i].max_wall_force_N = 20.0;
    steps[i].max_wall_force_arc_m = 0.1;
    steps[i].segment_wall_force_N = spike;
  }
  for (int i = 300; i < 320; ++i) {  // 20 ms at 12 N on segment 1
    steps[i].max_wall_force_N = 12.0;
    steps[i].max_wall_force_arc_m = 0.2;
    steps[i].segment_wall_force_N = press;
  }
  const auto acc = Accumulate(steps);  // damage over 8 N
  const Metrics m = acc.Result();
  EXPECT_EQ(m.damage_events, 1u);
  EXPECT_GT(m.damage_impulse_N_s, 0.0);
  EXPECT_EQ(acc.damage_map_N_s()[0], 0.0);
  EXPECT_GT(acc.damage_map_N_s()[1], 0.0);
  for (const Event& e : acc.Events()) {
    if (e.kind == EventKind::kDamage) {
      EXPECT_EQ(e.arc_m, 0.2);
    }
  }
}

TEST(Metrics, MaxInsertionIsTheDeepestInsertion) {
  auto steps = Steps(3);
  steps[0].inserted_m = 0.25;
  steps[1].inserted_m = 0.75;
  steps[2].inserted_m = 0.5;
  EXPECT_EQ(Accumulate(steps).Result().max_insertion_m, 0.75);
}

TEST(Metrics, EventsAreInTimeOrder) {
  auto steps = Steps(6);
  steps[4].max_wall_force_N = 5.0;
  steps[1].peak_stretch_m = 0.05;
  steps[2].fluoroscopy_on = true;
  const auto events = Accumulate(steps).Events();
  ASSERT_EQ(events.size(), 4u);  // pain, fluoro on, fluoro off, force
  for (std::size_t i = 1; i < events.size(); ++i) EXPECT_LE(events[i - 1].t_s, events[i].t_s);
}

}  // namespace
}  // namespace ves::training
