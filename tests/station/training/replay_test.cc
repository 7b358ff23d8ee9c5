#include "station/training/replay.h"

#include <gtest/gtest.h>

#include <cmath>

#include "station/training/case_model.h"
#include "station/training/session_file.h"
#include "tests/station/training/toolkit_operator.h"

namespace ves::training {
namespace {

// A synthetic colon: 0.2 m straight, then a 90-degree bend of radius 0.15 m,
// then 0.2 m straight; the last 4 points are labelled cecum. Small enough
// that a 2 s session runs in well under a second.
model::ModelParams TubeParams() {
  std::vector<Eigen::Vector3d> points;
  for (int i = 0; i <= 20; ++i) points.emplace_back(0.0, 0.0, 0.01 * i);
  for (int i = 1; i <= 24; ++i) {
    const double a = 0.5 * model::kPi * i / 24.0;
    points.emplace_back(0.15 * (1.0 - std::cos(a)), 0.0, 0.2 + 0.15 * std::sin(a));
  }
  for (int i = 1; i <= 20; ++i) points.emplace_back(0.15 + 0.01 * i, 0.0, 0.35);
  model::ModelParams params;
  params.colon = model::MakeColonFromPoints(points, 0.02, model::TissueParams{});
  for (std::size_t i = points.size() - 4; i < points.size(); ++i) {
    params.colon.points[i].region = model::Region::kCecum;
  }
  return params;
}

SessionConfig Config(const model::ModelParams& params, double seconds) {
  SessionConfig c;
  c.case_id = "tube";
  c.difficulty = v1::DIFFICULTY_MEDIUM;
  c.dt_s = params.dt_s;
  c.time_limit_s = seconds;
  c.thresholds = ThresholdsFor(params);
  return c;
}

TEST(Replay, ThresholdsPutTheCecumAtTheFirstCecumPoint) {
  const auto params = TubeParams();
  EXPECT_EQ(ThresholdsFor(params).cecum_arc_m,
            params.colon.points[params.colon.points.size() - 4].arc_m);
}

TEST(Replay, ReproducesAScriptedSessionExactly) {
  const auto params = TubeParams();
  for (const char* kind : {"novice", "expert"}) {
    v1::SessionRecord record;
    const RunResult live = RunScriptedSession(params, Config(params, 2.0), kind, 1000, &record);
    ASSERT_GT(live.steps, 0u) << kind;
    EXPECT_EQ(record.operator_kind(), kind);
    EXPECT_EQ(record.input_log().sample_count(), live.steps);
    // Through the session file, as the server or a supervisor would get it.
    const v1::SessionRecord back = DecodeSessionFile(EncodeSessionFile(record));
    const RunResult replayed = Replay(params, Config(params, 2.0), back.input_log());
    EXPECT_EQ(replayed, live) << kind << "\nlive:   " << SummaryLine(live)
                              << "\nreplay: " << SummaryLine(replayed);
    EXPECT_EQ(SummaryLine(replayed), SummaryLine(live));
    EXPECT_EQ(FromProto(record.metrics()), replayed.metrics);
  }
}

// A log of format version 1 (no abdominal press, no patient position) replays
// exactly as the session it records ran, and as the same inputs in the
// current format.
TEST(Replay, AVersion1LogReplaysExactlyAsItsSessionRan) {
  const auto params = TubeParams();
  for (const char* kind : {"novice", "expert"}) {
    v1::SessionRecord record;
    const RunResult live = RunScriptedSession(params, Config(params, 2.0), kind, 1000, &record);
    const auto inputs = DecodeInputLog(record.input_log());
    const v1::InputLog old = MakeInputLog(inputs, params.dt_s, 1);
    ASSERT_EQ(PeekInputLogFormatVersion(old.encoded()), 1u);
    const RunResult replayed = Replay(params, Config(params, 2.0), old);
    EXPECT_EQ(replayed, live) << kind << "\nlive:   " << SummaryLine(live)
                              << "\nreplay: " << SummaryLine(replayed);
    EXPECT_EQ(replayed, Replay(params, Config(params, 2.0), record.input_log())) << kind;
  }
}

TEST(Replay, PressAndTurnsReplayToTheSameSummary) {
  const auto params = TubeParams();
  ToolkitNovice op;
  v1::SessionRecord record;
  const RunResult live =
      RunScriptedSession(params, Config(params, 2.0), op, "toolkit-novice", 1000, &record);
  ASSERT_EQ(live.steps, 2000u);
  EXPECT_NEAR(live.metrics.press_llq_s, 0.5, 1e-9);
  EXPECT_NEAR(live.metrics.press_mid_s, 0.3, 1e-9);
  EXPECT_NEAR(live.metrics.left_lateral_s, 0.7, 1e-9);
  EXPECT_NEAR(live.metrics.right_lateral_s, 0.4, 1e-9);
  EXPECT_EQ(live.metrics.position_changes, 3u);
  const std::string line = SummaryLine(live);
  EXPECT_NE(line.find(" press_llq_s=0.5 press_mid_s=0.3 position_changes=3 "), std::string::npos)
      << line;
  const v1::SessionRecord back = DecodeSessionFile(EncodeSessionFile(record));
  EXPECT_EQ(back.input_log().format_version(), kInputLogFormatVersion);
  const RunResult replayed = Replay(params, Config(params, 2.0), back.input_log());
  EXPECT_EQ(replayed, live) << "live:   " << SummaryLine(live)
                            << "\nreplay: " << SummaryLine(replayed);
  EXPECT_EQ(SummaryLine(replayed), line);
  EXPECT_EQ(FromProto(back.metrics()), replayed.metrics);
}

TEST(ToStepInput, ThePressHoldsTheRegionsUnderTheHandAndThePositionTurnsThePatient) {
  InputSample in;
  model::StepInput s = ToStepInput(in);
  for (double pressure : s.abdominal_pressure) EXPECT_EQ(pressure, 0.0);
  EXPECT_EQ(s.patient_position, model::PatientPosition::kSupine);
  const auto pressed = [](const model::StepInput& step) {
    std::vector<model::Region> regions;
    for (std::size_t r = 0; r < step.abdominal_pressure.size(); ++r) {
      if (step.abdominal_pressure[r] == 1.0) regions.push_back(static_cast<model::Region>(r));
      else EXPECT_EQ(step.abdominal_pressure[r], 0.0) << r;
    }
    return regions;
  };
  // Left lower quadrant: the sigmoid apex and a mobile descending colon under the hand.
  in.abdominal_press = AbdominalPress::kLeftLowerQuadrant;
  EXPECT_EQ(pressed(ToStepInput(in)),
            (std::vector<model::Region>{model::Region::kSigmoid, model::Region::kDescending}));
  in.abdominal_press = AbdominalPress::kMidAbdomen;
  EXPECT_EQ(pressed(ToStepInput(in)), std::vector<model::Region>{model::Region::kTransverse});
  in.patient_position = PatientPosition::kLeftLateral;
  EXPECT_EQ(ToStepInput(in).patient_position, model::PatientPosition::kLeftLateral);
  in.patient_position = PatientPosition::kRightLateral;
  EXPECT_EQ(ToStepInput(in).patient_position, model::PatientPosition::kRightLateral);
}

TEST(SummaryLine, SaysWhatDidNotHappenWithADashAndGivesTheScoresScale) {
  RunResult r;
  r.outcome = Outcome::kTimedOut;
  r.metrics.max_tip_arc_m = 0.81234;
  r.metrics.pain_s = 12.345;
  r.metrics.peak_insertion_force_N = 3.14159;
  r.metrics.xray_s = 0.04;
  r.score = 34.25;
  r.deepest_region = "sigmoid";
  EXPECT_EQ(SummaryLine(r),
            "outcome=timed_out time_to_cecum_s=- inserted_at_cecum_m=- deepest_tip_arc_m=0.812 "
            "deepest_region=sigmoid pain_s=12.3 loop_s=0.0 peak_force_N=3.14 xray_s=0.0 "
            "press_llq_s=0.0 press_mid_s=0.0 position_changes=0 score=34.2/100");
  r.outcome = Outcome::kCecumReached;
  r.metrics.completed = true;
  r.metrics.time_to_cecum_s = 212.46;
  r.metrics.inserted_at_cecum_m = 1.0514;
  r.metrics.max_tip_arc_m = 1.45;
  r.deepest_region = "cecum";
  const std::string line = SummaryLine(r);
  EXPECT_NE(line.find("time_to_cecum_s=212.5 inserted_at_cecum_m=1.051 deepest_tip_arc_m=1.450 "
                      "deepest_region=cecum"),
            std::string::npos)
      << line;
}

TEST(Replay, TheDeepestRegionComesFromTheColon) {
  const auto params = TubeParams();
  v1::SessionRecord record;
  const RunResult live = RunScriptedSession(params, Config(params, 0.5), "novice", 0, &record);
  EXPECT_EQ(live.deepest_region, RegionNameAt(params.colon, live.metrics.max_tip_arc_m));
  EXPECT_EQ(RegionNameAt(params.colon, params.colon.points.back().arc_m + 1.0), "cecum");
  EXPECT_EQ(RegionNameAt(params.colon, 0.0), "unspecified");  // the tube's other points
}

TEST(Replay, ALogEndingEarlyReplaysAsAborted) {
  const auto params = TubeParams();
  v1::SessionRecord record;
  RunScriptedSession(params, Config(params, 1.0), "novice", 0, &record);
  auto inputs = DecodeInputLog(record.input_log());
  ASSERT_GT(inputs.size(), 100u);
  inputs.resize(100);
  const RunResult r = Replay(params, Config(params, 1.0), MakeInputLog(inputs, params.dt_s));
  EXPECT_EQ(r.outcome, Outcome::kAborted);
  EXPECT_EQ(r.steps, 100u);
}

TEST(Replay, SamplesAfterTheSessionFinishedAreRefused) {
  const auto params = TubeParams();
  v1::SessionRecord record;
  RunScriptedSession(params, Config(params, 0.5), "novice", 0, &record);
  auto inputs = DecodeInputLog(record.input_log());
  inputs.push_back(inputs.back());
  inputs.back().tick = inputs.size() - 1;
  EXPECT_THROW(Replay(params, Config(params, 0.5), MakeInputLog(inputs, params.dt_s)), ReplayError);
}

TEST(Replay, CorruptedLogIsRefused) {
  const auto params = TubeParams();
  v1::SessionRecord record;
  RunScriptedSession(params, Config(params, 0.5), "expert", 0, &record);
  v1::InputLog log = record.input_log();
  std::string bytes = log.encoded();
  bytes[bytes.size() / 2] ^= 0x40;
  log.set_encoded(bytes);
  EXPECT_THROW(Replay(params, Config(params, 0.5), log), InputLogError);
  log = record.input_log();
  log.set_encoded(log.encoded().substr(0, log.encoded().size() - 3));
  EXPECT_THROW(Replay(params, Config(params, 0.5), log), InputLogError);
}

TEST(Replay, RepeatTrainingRunsTheSameInputsToTheSameResult) {
  const auto params = TubeParams();
  v1::SessionRecord record;
  const RunResult first = RunScriptedSession(params, Config(params, 0.5), "novice", 0, &record);
  const auto inputs = DecodeInputLog(record.input_log());
  SessionRunner runner(params, Config(params, 0.5));
  for (int attempt = 0; attempt < 2; ++attempt) {
    runner.Start(0);
    for (const auto& in : inputs) runner.Step(in);
    EXPECT_EQ(runner.session().metrics(), first.metrics) << "attempt " << attempt;
    runner.Repeat();
  }
  EXPECT_EQ(runner.session().repeat_count(), 2);
}

TEST(Replay, UnknownOperatorIsRefused) {
  const auto params = TubeParams();
  EXPECT_THROW(RunScriptedSession(params, Config(params, 0.1), "robot", 0, nullptr),
               std::invalid_argument);
}

TEST(SessionRunner, ModelAndSessionRatesMustAgree) {
  const auto params = TubeParams();
  SessionConfig c = Config(params, 1.0);
  c.dt_s = 0.002;
  EXPECT_THROW(SessionRunner(params, c), std::invalid_argument);
}

}  // namespace
}  // namespace ves::training
