// The scripted expert on colons nobody tuned it for (issue #47): 20 colons
// from the generator (docs/case-generator.md), seeds 1-20. The expert decides
// from what a trainee can know (docs/scoring.md, "Scripted operators"), so it
// must reach the cecum of nearly all of them, cleanly.
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>

#include "patient_db/case_format.h"
#include "patient_db/case_generator.h"
#include "station/training/case_run.h"
#include "station/training/replay.h"
#include "station/training/session.h"
#include "station/training/session_runner.h"
#include "station/training/scripted_operator.h"

namespace ves::training {
namespace {

constexpr int kSeeds = 20;
constexpr int kMustReach = 18;  // issue #47: "on >= 18 of 20 generated colons"

TEST(GeneratedColons, TheExpertReachesTheCecumOfAtLeast18Of20WithoutDamage) {
  int reached = 0;
  int helped = 0;  // runs in which the assistant pressed or the patient was turned
  for (int seed = 1; seed <= kSeeds; ++seed) {
    const v1::ColonCase colon_case = patient_db::GenerateColonCase(seed);
    v1::SessionRecord record;
    long steps = 0, over_10N = 0;
    const RunResult run = RunScriptedCase(
        colon_case, DefaultEndoscopeSpec(), CaseModelOptions{}, "expert", 600.0, 0, &record,
        [&](const InputSample&, const SessionRunner& runner) {
          ++steps;
          if (runner.output().base_force_N > 10.0) ++over_10N;
        });
    const double over_10N_share = steps > 0 ? static_cast<double>(over_10N) / steps : 0.0;
    const Metrics& m = run.metrics;
    std::printf("seed %2d: %s; over 10 N %.1f %% of steps\n", seed, SummaryLine(run).c_str(),
                100.0 * over_10N_share);
    if (m.press_llq_s > 0.0 || m.press_mid_s > 0.0 || m.position_changes > 0) ++helped;
    if (run.outcome != Outcome::kCecumReached) continue;
    ++reached;
    EXPECT_EQ(m.damage_events, 0u) << "seed " << seed << ": " << SummaryLine(run);
    // Issue #47's hand: within 10 N 95 % of the time, within 45 N at its peak.
    EXPECT_LE(over_10N_share, 0.05) << "seed " << seed << ": " << SummaryLine(run);
    EXPECT_LE(m.peak_insertion_force_N, 45.0) << "seed " << seed << ": " << SummaryLine(run);
  }
  EXPECT_GE(reached, kMustReach);
  // Somewhere a loop resisted a pull-back, and the session kept the help asked for.
  EXPECT_GT(helped, 0);
}

// A colon gathered at rest (TissueParams::gathered_reserve: sigmoid 0.3,
// transverse 0.2; the shipped default is still 0, docs/model.md "Known
// limits"): a push loops the sigmoid
// and the tip stalls in pain past the sigmoid; the expert asks the assistant
// to press the left lower quadrant and reaches the cecum without damage.
TEST(GatheredSigmoid, TheExpertReachesStandardAdultsCecumWithTheAssistantsPress) {
  v1::ColonCase colon_case = patient_db::LoadCaseFile(std::filesystem::path(VES_SOURCE_DIR) /
                                                      "patient_db" / "cases" /
                                                      "standard-adult.textproto");
  for (auto& span : *colon_case.mutable_regions()) {
    if (span.region() == v1::REGION_SIGMOID) span.mutable_tissue()->set_gathered_reserve(0.3);
    if (span.region() == v1::REGION_TRANSVERSE) span.mutable_tissue()->set_gathered_reserve(0.2);
  }
  v1::SessionRecord record;
  const RunResult run = RunScriptedCase(colon_case, DefaultEndoscopeSpec(), CaseModelOptions{},
                                        "expert", 600.0, 0, &record);
  std::printf("standard-adult, reserve 0.3 / 0.2: %s; left lower quadrant pressed %.1f s\n",
              SummaryLine(run).c_str(), run.metrics.press_llq_s);
  EXPECT_EQ(run.outcome, Outcome::kCecumReached) << SummaryLine(run);
  EXPECT_GT(run.metrics.press_llq_s, 0.0);
  EXPECT_EQ(run.metrics.damage_events, 0u);
  EXPECT_LE(run.metrics.peak_insertion_force_N, 45.0);
}

}  // namespace
}  // namespace ves::training
