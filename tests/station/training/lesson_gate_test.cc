// A lesson's gate (station/training/lesson_gate.h): criteria on metrics, and
// the server's judge, which trusts the replay of the input log and never the
// metrics a record claims.
#include "station/training/lesson_gate.h"

#include <gtest/gtest.h>

#include "patient_db/case_format.h"
#include "station/training/case_model.h"
#include "station/training/case_run.h"
#include "station/training/input_log.h"
#include "tests/station/training/toolkit_operator.h"

namespace ves::training {
namespace {

using ::testing::PrintToString;

bool HasCheck(const GateResult& g, const std::string& text) {
  for (const auto& c : g.checks) {
    if (c.find(text) != std::string::npos) return true;
  }
  return false;
}

v1::Lesson Lenient() {
  v1::Lesson l;
  l.set_lesson_id("l1");
  l.set_time_limit_s(5);
  l.mutable_aids()->set_fluoroscopy_allowed(true);
  l.mutable_aids()->set_wireframe_allowed(true);
  return l;
}

TEST(CheckLessonGate, ThresholdsAreInclusive) {
  v1::Lesson l = Lenient();
  l.mutable_pass()->set_max_pain_s(10);
  l.mutable_pass()->set_min_max_tip_arc_m(0.15);
  v1::SessionMetrics m;
  m.set_duration_s(5);        // the whole time limit
  m.set_pain_s(10);           // exactly at the limit: passes
  m.set_max_tip_arc_m(0.15);  // exactly at the limit: passes
  EXPECT_TRUE(CheckLessonGate(l, m, 0, false).passed);
  m.set_pain_s(10.5);
  const GateResult g = CheckLessonGate(l, m, 0, false);
  EXPECT_FALSE(g.passed);
  EXPECT_TRUE(HasCheck(g, "pain_s 10.5 <= 10: FAILED"));
  EXPECT_TRUE(HasCheck(g, "max_tip_arc_m 0.15 >= 0.15: ok"));
}

// The scope in at the cecum tells a loop left in (the novice that pushes the
// whole 1.68 m scope round a mobile colon) from a reduced one.
TEST(CheckLessonGate, ScopeInAtTheCecumIsLimitedAndImpliesTheCecum) {
  v1::Lesson l = Lenient();
  l.mutable_pass()->set_max_inserted_at_cecum_m(1.45);
  v1::SessionMetrics m;
  m.set_duration_s(5);
  m.set_completed(true);
  m.set_inserted_at_cecum_m(1.45);  // exactly at the limit: passes
  EXPECT_TRUE(CheckLessonGate(l, m, 0, false).passed);
  m.set_inserted_at_cecum_m(1.68);
  GateResult g = CheckLessonGate(l, m, 0, false);
  EXPECT_FALSE(g.passed);
  EXPECT_TRUE(HasCheck(g, "inserted_at_cecum_m 1.68 <= 1.45: FAILED")) << PrintToString(g.checks);
  // Not reached: its 0 m must not count as a short scope.
  m.set_completed(false);
  m.set_inserted_at_cecum_m(0);
  g = CheckLessonGate(l, m, 0, false);
  EXPECT_FALSE(g.passed);
  EXPECT_TRUE(HasCheck(g, "cecum not reached: FAILED")) << PrintToString(g.checks);
  bool described = false;
  for (const auto& line : DescribePassCriteria(l)) {
    described = described || line == "inserted_at_cecum_m <= 1.45 m";
  }
  EXPECT_TRUE(described) << PrintToString(DescribePassCriteria(l));
}

TEST(CheckLessonGate, StoppingBeforeTheTimeLimitFailsUnlessTheCecumWasReached) {
  const v1::Lesson l = Lenient();  // 5 s, no other rule
  v1::SessionMetrics m;
  m.set_duration_s(4.999);  // the last step of a full 5 s run at dt = 1 ms
  EXPECT_TRUE(CheckLessonGate(l, m, 0, false).passed);
  m.set_duration_s(4.9);
  EXPECT_FALSE(CheckLessonGate(l, m, 0, false).passed);
  m.set_completed(true);  // the cecum ends a session early, legitimately
  EXPECT_TRUE(CheckLessonGate(l, m, 0, false).passed);
}

TEST(CheckLessonGate, CecumScoreAndAidsRules) {
  v1::Lesson l = Lenient();
  l.mutable_pass()->set_max_time_to_cecum_s(300);
  l.mutable_pass()->set_min_score(50);
  l.mutable_aids()->set_fluoroscopy_allowed(false);
  l.mutable_aids()->set_wireframe_allowed(false);
  v1::SessionMetrics m;
  m.set_completed(true);
  m.set_time_to_cecum_s(200);
  EXPECT_TRUE(CheckLessonGate(l, m, 60, false).passed);
  EXPECT_FALSE(CheckLessonGate(l, m, 49, false).passed);       // score
  EXPECT_FALSE(CheckLessonGate(l, m, 60, true).passed);        // wireframe used
  m.set_xray_s(0.001);
  EXPECT_FALSE(CheckLessonGate(l, m, 60, false).passed);       // any X-ray
  m.set_xray_s(0);
  m.set_time_to_cecum_s(301);
  EXPECT_FALSE(CheckLessonGate(l, m, 60, false).passed);       // too slow
  m.set_completed(false);
  m.set_time_to_cecum_s(0);  // not reached: 0 must not count as fast
  EXPECT_FALSE(CheckLessonGate(l, m, 60, false).passed);
}

class LessonJudge : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    colon_case_ = new v1::ColonCase(
        patient_db::LoadCaseFile(VES_SOURCE_DIR "/patient_db/cases/paper-sigmoid.textproto"));
    record_ = new v1::SessionRecord;
    // 5 s of the scripted novice, who switches fluoroscopy on at once.
    RunScriptedCase(*colon_case_, DefaultEndoscopeSpec(), {}, "novice", 5.0, 1000, record_);
  }
  static void TearDownTestSuite() {
    delete colon_case_;
    delete record_;
  }
  v1::Lesson LessonFor(const v1::SessionRecord& r) const {
    v1::Lesson l = Lenient();
    l.mutable_case_ref()->set_case_id("paper-sigmoid");
    l.mutable_case_ref()->set_payload_sha256_hex(patient_db::CasePayloadSha256Hex(*colon_case_));
    *l.mutable_scope() = DefaultEndoscopeSpec();
    (void)r;
    return l;
  }
  v1::SessionRecord Record() const {
    v1::SessionRecord r = *record_;
    r.set_lesson_id("l1");
    r.set_case_sha256_hex(patient_db::CasePayloadSha256Hex(*colon_case_));
    return r;
  }
  static v1::ColonCase* colon_case_;
  static v1::SessionRecord* record_;
};
v1::ColonCase* LessonJudge::colon_case_ = nullptr;
v1::SessionRecord* LessonJudge::record_ = nullptr;

TEST_F(LessonJudge, AnHonestRecordIsJudgedOnItsExactReplay) {
  const v1::SessionRecord r = Record();
  ASSERT_GT(r.metrics().xray_s(), 4.0);  // the novice had the X-ray on
  const GateResult g = JudgeLessonSession(LessonFor(r), *colon_case_, r);
  EXPECT_TRUE(g.passed) << ::testing::PrintToString(g.checks);
  EXPECT_DOUBLE_EQ(g.score, r.score());  // replay is bit-exact on the same build
}

// The abdominal press and the patient's turns are in the log: `ves-station
// replay` (ReplayRecord) and the server's judge replay them as they ran.
TEST_F(LessonJudge, PressAndTurnsReplayToTheSameSummaryAndVerdict) {
  const CaseRun run = PrepareCaseRun(*colon_case_, DefaultEndoscopeSpec(), {}, 5.0);
  ToolkitNovice op;
  v1::SessionRecord r;
  const RunResult live = RunScriptedSession(run.params, run.config, op, "toolkit-novice", 1000, &r);
  *r.mutable_replay_setup() = MakeReplaySetup(*colon_case_, {}, 5.0);
  r.set_lesson_id("l1");
  r.set_case_sha256_hex(patient_db::CasePayloadSha256Hex(*colon_case_));
  ASSERT_EQ(live.metrics.position_changes, 3u);
  ASSERT_GT(live.metrics.press_llq_s, 0.0);
  ASSERT_GT(live.metrics.press_mid_s, 0.0);
  const RunResult replayed = ReplayRecord(r);
  EXPECT_EQ(SummaryLine(replayed), SummaryLine(live));
  EXPECT_EQ(replayed, live);
  const GateResult g = JudgeLessonSession(LessonFor(r), *colon_case_, r);
  EXPECT_TRUE(g.passed) << PrintToString(g.checks);
  EXPECT_DOUBLE_EQ(g.score, live.score);
}

TEST_F(LessonJudge, AForgedRecordIsJudgedByItsReplayNotItsClaims) {
  v1::SessionRecord forged = Record();
  v1::Lesson lesson = LessonFor(forged);
  lesson.mutable_pass()->set_max_xray_s(1.0);
  // Altered after the run: no X-ray, a perfect score.
  forged.mutable_metrics()->set_xray_s(0.0);
  forged.set_score(100.0);
  EXPECT_TRUE(CheckLessonGate(lesson, forged.metrics(), forged.score(), false).passed);
  const GateResult g = JudgeLessonSession(lesson, *colon_case_, forged);
  EXPECT_FALSE(g.passed);
  EXPECT_TRUE(HasCheck(g, "xray_s 5 <= 1: FAILED")) << ::testing::PrintToString(g.checks);
  EXPECT_DOUBLE_EQ(g.score, record_->score());
}

TEST_F(LessonJudge, AFluoroscopyFreeLessonFailsASessionThatUsedIt) {
  v1::SessionRecord r = Record();
  v1::Lesson lesson = LessonFor(r);
  lesson.mutable_aids()->set_fluoroscopy_allowed(false);
  r.mutable_metrics()->set_xray_s(0.0);  // claimed away; the inputs still had it on
  const GateResult g = JudgeLessonSession(lesson, *colon_case_, r);
  EXPECT_FALSE(g.passed);
  EXPECT_TRUE(HasCheck(g, "fluoroscopy not allowed")) << ::testing::PrintToString(g.checks);
}

TEST_F(LessonJudge, TheLessonsCaseAndLimitsAreNotTheRecordsToChoose) {
  v1::SessionRecord r = Record();
  const v1::Lesson lesson = LessonFor(r);
  r.set_case_sha256_hex(std::string(64, '0'));
  GateResult g = JudgeLessonSession(lesson, *colon_case_, r);
  EXPECT_FALSE(g.passed);
  EXPECT_TRUE(HasCheck(g, "case sha256 000000000000")) << ::testing::PrintToString(g.checks);
  r = Record();
  r.mutable_replay_setup()->set_time_limit_s(6.0);  // longer than the lesson's 5 s
  EXPECT_FALSE(JudgeLessonSession(lesson, *colon_case_, r).passed);
  r = Record();
  r.mutable_scope()->set_working_length_m(2.0);
  EXPECT_FALSE(JudgeLessonSession(lesson, *colon_case_, r).passed);
  r = Record();
  r.set_lesson_id("other");
  EXPECT_FALSE(JudgeLessonSession(lesson, *colon_case_, r).passed);
}

TEST_F(LessonJudge, ALogThatCannotBeReplayedFails) {
  v1::SessionRecord r = Record();
  r.mutable_input_log()->set_encoded("garbage");  // not even a header: refused unread
  GateResult g = JudgeLessonSession(LessonFor(r), *colon_case_, r);
  EXPECT_FALSE(g.passed);
  EXPECT_TRUE(g.rejected);
  EXPECT_TRUE(HasCheck(g, "rejected: input log: truncated header")) << PrintToString(g.checks);
  r = Record();
  std::string encoded = r.input_log().encoded();
  encoded[encoded.size() / 2] ^= 0x20;  // a header that fits, data that does not
  r.mutable_input_log()->set_encoded(encoded);
  g = JudgeLessonSession(LessonFor(r), *colon_case_, r);
  EXPECT_FALSE(g.passed);
  EXPECT_TRUE(HasCheck(g, "replay: input log:")) << PrintToString(g.checks);
}

// The input log's header says how many samples follow. More than the lesson's
// time limit allows is refused from the header alone: a 177 KB record claiming
// 20 million samples once took the server to 2.8 GB while it decoded them.
TEST_F(LessonJudge, ALogClaimingMoreSamplesThanTheTimeLimitAllowsIsRejectedUndecoded) {
  v1::SessionRecord r = Record();
  const std::vector<InputSample> idle(20000);  // 20 s of nothing on a 5 s lesson
  std::vector<InputSample> ticked(idle);
  for (std::size_t i = 0; i < ticked.size(); ++i) ticked[i].tick = i;
  *r.mutable_input_log() = MakeInputLog(ticked, r.input_log().dt_s());
  GateResult g = JudgeLessonSession(LessonFor(r), *colon_case_, r);
  EXPECT_FALSE(g.passed);
  EXPECT_TRUE(g.rejected);
  EXPECT_TRUE(HasCheck(g, "rejected: the input log claims 20000 samples, more than the 5001 of "
                          "a 5 s lesson")) << PrintToString(g.checks);
  // The header's count alone decides: 20 million claimed in front of a short log.
  std::string encoded = Record().input_log().encoded();
  const std::uint64_t claimed = 20'000'000;
  for (int i = 0; i < 8; ++i) encoded[4 + i] = static_cast<char>((claimed >> (8 * i)) & 0xff);
  r.mutable_input_log()->set_encoded(encoded);
  g = JudgeLessonSession(LessonFor(r), *colon_case_, r);
  EXPECT_TRUE(g.rejected);
  EXPECT_TRUE(HasCheck(g, "claims 20000000 samples")) << PrintToString(g.checks);
}

TEST_F(LessonJudge, ARecordOverTheMemoryOrCpuBudgetIsRejected) {
  const v1::SessionRecord r = Record();
  const std::uint64_t samples = PeekInputSampleCount(r.input_log().encoded());
  ASSERT_GT(samples, 4000u);
  JudgeBudget small_memory;
  small_memory.memory_bytes = 1000 * kJudgedBytesPerSample;
  GateResult g = JudgeLessonSession(LessonFor(r), *colon_case_, r, nullptr, small_memory);
  EXPECT_TRUE(g.rejected);
  EXPECT_FALSE(g.passed);
  EXPECT_TRUE(HasCheck(g, "over the memory budget of")) << PrintToString(g.checks);
  JudgeBudget no_cpu;
  no_cpu.cpu_base_s = 0.0;
  no_cpu.cpu_per_limit_s = 0.0;
  g = JudgeLessonSession(LessonFor(r), *colon_case_, r, nullptr, no_cpu);
  EXPECT_TRUE(g.rejected);
  EXPECT_FALSE(g.passed);
  EXPECT_TRUE(HasCheck(g, "CPU budget after 256 steps")) << PrintToString(g.checks);
  // Within the default budgets the same record is judged as always.
  EXPECT_FALSE(JudgeLessonSession(LessonFor(r), *colon_case_, r).rejected);
}

TEST_F(LessonJudge, AStepTheStationNeverUsesIsRejected) {
  v1::SessionRecord r = Record();
  r.mutable_input_log()->set_dt_s(1e-6);  // a million steps a second of lesson
  const GateResult g = JudgeLessonSession(LessonFor(r), *colon_case_, r);
  EXPECT_TRUE(g.rejected);
  EXPECT_TRUE(HasCheck(g, "input_log.dt_s 1e-06 is outside")) << PrintToString(g.checks);
}

}  // namespace
}  // namespace ves::training
