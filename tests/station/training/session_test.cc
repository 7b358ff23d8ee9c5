#include "station/training/session.h"

#include <gtest/gtest.h>

#include <regex>
#include <set>

#include "station/training/uuid.h"

namespace ves::training {
namespace {

constexpr double kDt_s = 0.25;

SessionConfig Config() {
  SessionConfig c;
  c.trainee_id = "t-1";
  c.case_id = "standard-adult";
  c.case_version = 3;
  c.difficulty = v1::DIFFICULTY_EASY;
  c.dt_s = kDt_s;
  c.time_limit_s = 2.0;
  c.thresholds.cecum_arc_m = 1.0;
  c.scope.set_id("scope-a");
  return c;
}

StepObservation Obs(const Session& s, double tip_arc_m) {
  StepObservation o;
  o.dt_s = kDt_s;
  o.t_s = static_cast<double>(s.steps() + 1) * kDt_s;
  o.tip_arc_m = tip_arc_m;
  o.inserted_m = tip_arc_m;
  return o;
}

InputSample Push(double force_N) {
  InputSample in;
  in.push_force_N = force_N;
  return in;
}

TEST(Session, GoesReadyRunningFinishedWhenTheCecumIsReached) {
  Session s(Config());
  EXPECT_EQ(s.state(), SessionState::kReady);
  s.Start(1000);
  EXPECT_EQ(s.state(), SessionState::kRunning);
  s.Record(Push(1.0), Obs(s, 0.5));
  EXPECT_EQ(s.state(), SessionState::kRunning);
  s.Record(Push(1.0), Obs(s, 1.0));
  EXPECT_EQ(s.state(), SessionState::kFinished);
  EXPECT_EQ(s.outcome(), Outcome::kCecumReached);
  EXPECT_EQ(s.metrics().time_to_cecum_s, 0.5);
}

TEST(Session, TimesOutAtTheTimeLimit) {
  Session s(Config());
  s.Start(0);
  for (int i = 0; i < 7; ++i) s.Record(Push(1.0), Obs(s, 0.1));
  EXPECT_EQ(s.state(), SessionState::kRunning);  // 1.75 s < 2 s
  s.Record(Push(1.0), Obs(s, 0.1));
  EXPECT_EQ(s.state(), SessionState::kFinished);
  EXPECT_EQ(s.outcome(), Outcome::kTimedOut);
}

TEST(Session, AbortFinishesARunningSession) {
  Session s(Config());
  EXPECT_THROW(s.Abort(), std::logic_error);
  s.Start(0);
  s.Record(Push(1.0), Obs(s, 0.1));
  s.Abort();
  EXPECT_EQ(s.outcome(), Outcome::kAborted);
  EXPECT_THROW(s.Record(Push(1.0), Obs(s, 0.1)), std::logic_error);
}

TEST(Session, RecordOrStartOutOfOrderIsRefused) {
  Session s(Config());
  EXPECT_THROW(s.Record(Push(1.0), Obs(s, 0.1)), std::logic_error);
  s.Start(0);
  EXPECT_THROW(s.Start(0), std::logic_error);
  EXPECT_THROW(s.ToRecord(NewUuidV4(), 0), std::logic_error);
}

TEST(Session, RepeatTrainingRestartsTheSameCaseWithAnEmptyLog) {
  Session s(Config());
  s.Start(0);
  s.Record(Push(1.0), Obs(s, 1.0));
  ASSERT_EQ(s.state(), SessionState::kFinished);
  s.Repeat();
  EXPECT_EQ(s.state(), SessionState::kReady);
  EXPECT_EQ(s.outcome(), Outcome::kNone);
  EXPECT_EQ(s.steps(), 0u);
  EXPECT_EQ(s.repeat_count(), 1);
  EXPECT_EQ(s.config().case_id, "standard-adult");
  EXPECT_EQ(s.metrics(), Metrics{});
  s.Start(10);
  s.Record(Push(1.0), Obs(s, 1.0));
  const v1::SessionRecord r = s.ToRecord(NewUuidV4(), 20);
  ASSERT_GE(r.events_size(), 1);
  EXPECT_EQ(r.events(0).kind(), v1::EVENT_KIND_REPEAT);
  EXPECT_EQ(r.events(0).value(), 1.0);
}

TEST(Session, RecordCarriesMetricsScoreAndTheQuantizedInputLog) {
  Session s(Config());
  s.Start(1000);
  s.Record(Push(1.23456), Obs(s, 0.5));
  s.Record(Push(2.0), Obs(s, 1.0));
  const std::string uuid = NewUuidV4();
  const v1::SessionRecord r = s.ToRecord(uuid, 1500);
  EXPECT_EQ(r.uuid(), uuid);
  EXPECT_EQ(r.case_id(), "standard-adult");
  EXPECT_EQ(r.case_version(), 3u);
  EXPECT_EQ(r.outcome(), v1::OUTCOME_CECUM_REACHED);
  EXPECT_EQ(r.start_unix_ms(), 1000);
  EXPECT_EQ(r.end_unix_ms(), 1500);
  EXPECT_EQ(r.scope().id(), "scope-a");
  EXPECT_EQ(FromProto(r.metrics()), s.metrics());
  EXPECT_EQ(r.score(), s.score());
  EXPECT_EQ(r.input_log().dt_s(), kDt_s);
  const auto inputs = DecodeInputLog(r.input_log());
  ASSERT_EQ(inputs.size(), 2u);
  EXPECT_EQ(inputs[0].tick, 0u);
  EXPECT_EQ(inputs[1].tick, 1u);
  EXPECT_NEAR(inputs[0].push_force_N, 1.2346, 1e-12);
}

TEST(Session, InvalidConfigIsRefused) {
  SessionConfig c = Config();
  c.dt_s = 0.0;
  EXPECT_THROW(Session{c}, std::invalid_argument);
  c = Config();
  c.time_limit_s = -1.0;
  EXPECT_THROW(Session{c}, std::invalid_argument);
}

TEST(Uuid, FormatIsVersion4Variant1LowerCase) {
  const std::regex pattern("^[0-9a-f]{8}-[0-9a-f]{4}-4[0-9a-f]{3}-[89ab][0-9a-f]{3}-[0-9a-f]{12}$");
  EXPECT_TRUE(std::regex_match(FormatUuidV4(~0ULL, ~0ULL), pattern));
  EXPECT_TRUE(std::regex_match(FormatUuidV4(0, 0), pattern));
  EXPECT_EQ(FormatUuidV4(0x0123456789abcdefULL, 0xfedcba9876543210ULL),
            "01234567-89ab-4def-bedc-ba9876543210");
}

TEST(Uuid, FreshUuidsDiffer) {
  std::set<std::string> seen;
  for (int i = 0; i < 1000; ++i) seen.insert(NewUuidV4());
  EXPECT_EQ(seen.size(), 1000u);
}

}  // namespace
}  // namespace ves::training
