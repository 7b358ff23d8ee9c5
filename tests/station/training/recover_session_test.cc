// A session the station did not finish recording, recovered from its
// journal's header and inputs (training::RecoverSession, docs/station-run.md,
// "Journal"): the record a replay of those inputs gives, aborted when they
// end while the session runs.
#include <gtest/gtest.h>

#include <vector>

#include "patient_db/case_format.h"
#include "station/training/case_run.h"
#include "station/training/input_log.h"
#include "station/training/replay.h"

namespace ves::training {
namespace {

class RecoverSessionTest : public ::testing::Test {
 protected:
  void SetUp() override {
    colon_case_ =
        patient_db::LoadCaseFile(VES_SOURCE_DIR "/patient_db/cases/paper-sigmoid.textproto");
    // 4 s of the scripted expert: the inputs a station would have journaled.
    live_ = RunScriptedCase(colon_case_, DefaultEndoscopeSpec(), {}, "expert", 4.0, 1'000'000,
                            &record_);
    inputs_ = DecodeInputLog(record_.input_log());
    CaseRun run = PrepareReplay(record_);
    run.config.trainee_id = "t-1";
    run.config.station_id = "station-7";
    run.config.lesson_id = "lesson-3";
    run.config.case_sha256_hex = "ab12";
    header_ = RecordHeader(run.config, "0b7d1c52-5a9c-4e0e-9a55-0c4d1a3f8e21", 1'000'000);
    *header_.mutable_replay_setup() = record_.replay_setup();
  }

  v1::ColonCase colon_case_;
  v1::SessionRecord record_;
  RunResult live_;
  std::vector<InputSample> inputs_;
  v1::SessionRecord header_;
};

TEST_F(RecoverSessionTest, AnInterruptedSessionIsTheAbortedReplayOfItsJournaledInputs) {
  ASSERT_EQ(inputs_.size(), 4000u);
  // The station died 2.5 s in: the inputs that reached the disk.
  const std::vector<InputSample> journaled(inputs_.begin(), inputs_.begin() + 2500);
  const v1::SessionRecord recovered = RecoverSession(header_, journaled);
  EXPECT_EQ(recovered.outcome(), v1::OUTCOME_ABORTED);
  EXPECT_EQ(recovered.uuid(), header_.uuid());
  EXPECT_EQ(recovered.trainee_id(), "t-1");
  EXPECT_EQ(recovered.station_id(), "station-7");
  EXPECT_EQ(recovered.lesson_id(), "lesson-3");
  EXPECT_EQ(recovered.case_id(), "paper-sigmoid");
  EXPECT_EQ(recovered.case_sha256_hex(), "ab12");
  EXPECT_EQ(recovered.start_unix_ms(), 1'000'000);
  EXPECT_EQ(recovered.end_unix_ms(), 1'002'500);
  EXPECT_DOUBLE_EQ(recovered.metrics().duration_s(), 2.5);
  EXPECT_EQ(recovered.input_log().sample_count(), 2500u);
  // The record replays like any other: the same metrics from its own log.
  const RunResult replayed = ReplayRecord(recovered);
  EXPECT_EQ(replayed.outcome, Outcome::kAborted);
  EXPECT_DOUBLE_EQ(replayed.metrics.duration_s, recovered.metrics().duration_s());
  EXPECT_DOUBLE_EQ(replayed.metrics.peak_insertion_force_N,
                   recovered.metrics().peak_insertion_force_n());
  EXPECT_DOUBLE_EQ(replayed.score, recovered.score());
}

TEST_F(RecoverSessionTest, AllOfASessionsInputsGiveTheLiveSessionsResult) {
  // Died after the session ended but before its record was stored: the
  // recovered record has the live session's outcome and metrics.
  const v1::SessionRecord recovered = RecoverSession(header_, inputs_);
  EXPECT_EQ(static_cast<int>(recovered.outcome()), static_cast<int>(live_.outcome));
  EXPECT_EQ(FromProto(recovered.metrics()), live_.metrics);
  EXPECT_DOUBLE_EQ(recovered.score(), live_.score);
}

TEST_F(RecoverSessionTest, InputsOutOfSequenceOrAnUnusableHeaderAreRefused) {
  std::vector<InputSample> gap(inputs_.begin(), inputs_.begin() + 100);
  gap.insert(gap.end(), inputs_.begin() + 200, inputs_.begin() + 300);  // 100 dropped
  EXPECT_THROW(RecoverSession(header_, gap), ReplayError);
  v1::SessionRecord no_setup = header_;
  no_setup.clear_replay_setup();
  EXPECT_THROW(RecoverSession(no_setup, inputs_), ReplayError);
  // More inputs than the session's time limit allows.
  std::vector<InputSample> too_many = inputs_;
  for (std::uint64_t tick = too_many.size(); tick < 4100; ++tick) {
    InputSample more = inputs_.back();
    more.tick = tick;
    too_many.push_back(more);
  }
  EXPECT_THROW(RecoverSession(header_, too_many), ReplayError);
}

}  // namespace
}  // namespace ves::training
