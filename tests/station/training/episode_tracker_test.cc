#include "station/training/episode_tracker.h"

#include <gtest/gtest.h>

#include <vector>

namespace ves::training {
namespace {

// dt = 0.25 s is exact in binary, so sums of durations compare exactly.
constexpr double kDt_s = 0.25;

void Feed(EpisodeTracker* tracker, const std::vector<int>& over) {
  for (std::size_t i = 0; i < over.size(); ++i) {
    const double t_s = (static_cast<double>(i) + 1.0) * kDt_s;
    tracker->Update(t_s, kDt_s, over[i] != 0, over[i], 0.1 * static_cast<double>(i), over[i] - 0.5);
  }
  tracker->Finish();
}

TEST(EpisodeTracker, SeparateRunsFartherThanTheGapAreSeparateEpisodes) {
  // Runs of 2 and 3 steps separated by 4 steps (1 s) with a 0.5 s merge gap.
  EpisodeTracker tracker(0.5);
  Feed(&tracker, {1, 1, 0, 0, 0, 0, 1, 1, 1, 0});
  ASSERT_EQ(tracker.episodes().size(), 2u);
  EXPECT_EQ(tracker.episodes()[0].start_s, 0.0);
  EXPECT_EQ(tracker.episodes()[0].duration_s, 0.5);
  EXPECT_EQ(tracker.episodes()[1].start_s, 1.5);
  EXPECT_EQ(tracker.episodes()[1].duration_s, 0.75);
  EXPECT_EQ(tracker.total_s(), 1.25);
}

TEST(EpisodeTracker, RunsCloserThanTheGapMergeWithoutCountingTheGap) {
  // One 0.25 s gap < 0.5 s merge gap: one episode of 4 over-steps = 1 s.
  EpisodeTracker tracker(0.5);
  Feed(&tracker, {1, 1, 0, 1, 1, 0});
  ASSERT_EQ(tracker.episodes().size(), 1u);
  EXPECT_EQ(tracker.episodes()[0].duration_s, 1.0);
}

TEST(EpisodeTracker, PeakAndExcessIntegralAreTracked) {
  EpisodeTracker tracker(0.0);
  tracker.Update(0.25, kDt_s, true, 5.0, 0.3, 1.0);
  tracker.Update(0.5, kDt_s, true, 7.0, 0.4, 3.0);
  tracker.Update(0.75, kDt_s, true, 6.0, 0.5, 2.0);
  tracker.Finish();
  ASSERT_EQ(tracker.episodes().size(), 1u);
  EXPECT_EQ(tracker.episodes()[0].peak_value, 7.0);
  EXPECT_EQ(tracker.episodes()[0].peak_arc_m, 0.4);
  // (1 + 3 + 2) * 0.25 = 1.5
  EXPECT_EQ(tracker.episodes()[0].excess_integral, 1.5);
}

TEST(EpisodeTracker, NegativeGapIsRefused) {
  EXPECT_THROW(EpisodeTracker(-1.0), std::invalid_argument);
}

}  // namespace
}  // namespace ves::training
