// The session pages' series (docs/web.md, "Session series") against a real
// server on loopback: computed once in the background after an upload,
// stored and served as stored; computed on first view for a session stored
// without one, then stored; a third concurrent computation answers 429 and a
// later ask succeeds; bounded for long sessions; the lesson verdict on the
// session's JSON.
#include <gtest/gtest.h>

#include <chrono>
#include <nlohmann/json.hpp>
#include <random>
#include <thread>

#include "patient_db/case_bundle.h"
#include "server/auth.h"
#include "server/session_series.h"
#include "station/training/case_run.h"
#include "tests/integration/test_server.h"
#include "tests/server/web_client.h"
#include "tests/server/web_fixture.h"

namespace ves::server::testing {
namespace {

using nlohmann::json;
using patient_db::StoreRole;

class WebSeriesTest : public WebServerTest {
 protected:
  void SetUp() override {
    server_.AddTrainee("t1", "north");
    server_.AddTrainee("s1", "south");
    PutSampleCase(server_.store(), "north");
    supervisor_ = server_.MakeToken(StoreRole::kSupervisor, "north");
    south_supervisor_ = server_.MakeToken(StoreRole::kSupervisor, "south");
    station_ = server_.MakeToken(StoreRole::kStation, "north");
  }

  // The scripted expert's session of `seconds` on the sample case, for t1.
  ves::v1::SessionRecord Scripted(double seconds, double* final_tip_arc_m = nullptr) {
    ves::v1::SessionRecord record;
    training::RunScriptedCase(
        SampleCase(), ves::v1::EndoscopeSpec(), {}, "expert", seconds, 1'700'000'000'000, &record,
        [&](const training::InputSample&, const training::SessionRunner& runner) {
          if (final_tip_arc_m) *final_tip_arc_m = runner.observation().tip_arc_m;
        });
    record.set_trainee_id("t1");
    record.set_station_id("station-1");
    record.set_case_id(SampleCase().id());
    record.set_case_version(SampleCase().version());
    record.set_case_sha256_hex(patient_db::CasePayloadSha256Hex(SampleCase()));
    return record;
  }

  // Stored as a server before series existed stored it: no series, none queued
  // (nor for the lesson judge: the row names no lesson).
  void StoreWithoutSeries(const ves::v1::SessionRecord& record) {
    patient_db::SessionRow row;
    row.uuid = record.uuid();
    row.trainee_id = record.trainee_id();
    row.institution = "north";
    row.case_id = record.case_id();
    row.case_version = record.case_version();
    row.station_id = record.station_id();
    row.start_unix_ms = record.start_unix_ms();
    row.end_unix_ms = record.end_unix_ms();
    row.body = record.SerializeAsString();
    row.body_sha256_hex = Sha256Hex(row.body);
    row.stored_unix_ms = 1;
    patient_db::WriteBatch batch;
    batch.sessions.push_back(row);
    ASSERT_TRUE(server_.store().CommitBatch(batch).ok());
  }

  std::string supervisor_, south_supervisor_, station_;
};

TEST_F(WebSeriesTest, SeriesIsComputedAfterUploadStoredAndServedAsStored) {
  double final_tip_arc_m = 0;
  const ves::v1::SessionRecord record = Scripted(8.0, &final_tip_arc_m);
  ves::v1::UploadSessionResponse up;
  const grpc::Status s = UploadSession(server_.Client(station_), record, &up);
  ASSERT_TRUE(s.ok()) << s.error_message();
  // The background worker computes it without anyone asking.
  auto stored = server_.store().GetSessionSeries(record.uuid());
  for (int i = 0; i < 600 && !stored.ok(); ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    stored = server_.store().GetSessionSeries(record.uuid());
  }
  ASSERT_TRUE(stored.ok()) << "no series within 60 s: " << stored.status.message;
  EXPECT_EQ(stored.value.format_version, kSeriesFormatVersion);
  EXPECT_EQ(server_.server().series().computed_in_background(), 1u);

  const HttpResult r = Get("/api/v1/sessions/" + record.uuid() + "/series", supervisor_);
  ASSERT_EQ(r.status, 200) << r.body;
  EXPECT_EQ(r.body, stored.value.json);  // served as stored, not recomputed
  EXPECT_EQ(server_.server().series().computed_on_view(), 0u);
  const json series = json::parse(r.body);
  EXPECT_EQ(series["v"], kSeriesFormatVersion);
  EXPECT_EQ(series["uuid"], record.uuid());
  const json& frames = series["frames"];
  ASSERT_GT(frames.size(), 70u);  // 10 Hz over 8 s
  EXPECT_NEAR(frames.back()["tip_arc_m"].get<double>(), final_tip_arc_m, 1e-5);
  EXPECT_NEAR(series["final_tip_arc_m"].get<double>(), final_tip_arc_m, 1e-9);
  ASSERT_TRUE(frames[0].contains("scope_mm")) << frames[0].dump();
  ASSERT_TRUE(frames.back().contains("colon_mm"));
  EXPECT_LE(frames.back()["colon_mm"].size(), static_cast<size_t>(kSeriesShapePoints) + 1);
  // The summary carries no verdict for a free run.
  const json summary = json::parse(Get("/api/v1/sessions/" + record.uuid(), supervisor_).body);
  EXPECT_TRUE(summary["lesson_verdict"].is_null()) << summary["lesson_verdict"].dump();
  // The read rules of the session: another institution is told nothing.
  EXPECT_EQ(Get("/api/v1/sessions/" + record.uuid() + "/series", south_supervisor_).status, 404);
}

TEST_F(WebSeriesTest, ASessionStoredWithoutSeriesGetsItOnFirstViewThenStored) {
  const ves::v1::SessionRecord record = Scripted(5.0);
  StoreWithoutSeries(record);
  ASSERT_EQ(server_.store().GetSessionSeries(record.uuid()).status.code,
            patient_db::StoreCode::kNotFound);
  const HttpResult first = Get("/api/v1/sessions/" + record.uuid() + "/series", supervisor_);
  ASSERT_EQ(first.status, 200) << first.body;
  EXPECT_EQ(server_.server().series().computed_on_view(), 1u);
  auto stored = server_.store().GetSessionSeries(record.uuid());
  ASSERT_TRUE(stored.ok()) << stored.status.message;
  EXPECT_EQ(stored.value.json, first.body);
  const HttpResult again = Get("/api/v1/sessions/" + record.uuid() + "/series", supervisor_);
  ASSERT_EQ(again.status, 200);
  EXPECT_EQ(again.body, first.body);
  EXPECT_EQ(server_.server().series().computed_on_view(), 1u);  // once
  // A record that cannot be replayed says so (and nothing is stored).
  std::mt19937_64 rng(3);
  const ves::v1::SessionRecord bad = MakeRecord(NewUuid(rng), "t1", 1);
  StoreWithoutSeries(bad);
  const HttpResult refused = Get("/api/v1/sessions/" + bad.uuid() + "/series", supervisor_);
  EXPECT_EQ(refused.status, 409) << refused.body;
  EXPECT_NE(refused.body.find("cannot be replayed"), std::string::npos) << refused.body;
  EXPECT_FALSE(server_.store().GetSessionSeries(bad.uuid()).ok());
}

TEST_F(WebSeriesTest, AThirdConcurrentComputationIsBusyAndALaterAskSucceeds) {
  std::vector<std::string> uuids;
  for (int i = 0; i < 3; ++i) {
    const ves::v1::SessionRecord record = Scripted(30.0);
    StoreWithoutSeries(record);
    uuids.push_back(record.uuid());
  }
  std::vector<HttpResult> results(3);
  std::vector<std::thread> threads;
  for (int i = 0; i < 3; ++i) {
    threads.emplace_back(
        [&, i] { results[i] = Get("/api/v1/sessions/" + uuids[i] + "/series", supervisor_); });
  }
  for (auto& t : threads) t.join();
  int ok = 0, busy = 0;
  for (int i = 0; i < 3; ++i) {
    if (results[i].status == 200) ++ok;
    if (results[i].status == 429) {
      ++busy;
      EXPECT_NE(results[i].body.find("replays are running; ask again"), std::string::npos)
          << results[i].body;
      EXPECT_NE(results[i].body.find("RESOURCE_EXHAUSTED"), std::string::npos);
      // Asked again once the others are done, it is computed.
      const HttpResult later = Get("/api/v1/sessions/" + uuids[i] + "/series", supervisor_);
      EXPECT_EQ(later.status, 200) << later.body;
    }
  }
  EXPECT_EQ(ok, 2);
  EXPECT_EQ(busy, 1);
  EXPECT_EQ(server_.server().series().computed_on_view(), 3u);
}

// A 10-minute session at 1 kHz with a shape every step would be ~200 MB of
// JSON; the series keeps at most the bounded frames, the first and the last.
TEST(SessionSeriesJson, ALongSessionIsThinnedWithinTheBounds) {
  SessionReplay replay;
  for (int i = 0; i <= 60000; ++i) {
    ReplayFrame f;
    f.t_s = i * 0.01;
    f.tip_arc_m = i * 1e-5;
    f.pain = (i / 1000) % 2 == 1;
    for (int p = 0; p < kSeriesShapePoints; ++p) {
      f.scope_mm.emplace_back(-1000 + p, 1000 - p);
      f.colon_mm.emplace_back(-1500 + p, 1500 - p);
    }
    replay.frames.push_back(std::move(f));
  }
  const json series = SeriesJson("u", replay, 100, 100);
  const json& frames = series["frames"];
  EXPECT_LE(frames.size(), static_cast<size_t>(kSeriesMaxPlotFrames) + 1);
  EXPECT_GE(frames.size(), static_cast<size_t>(kSeriesMaxPlotFrames) / 2);
  size_t shapes = 0;
  for (const json& f : frames) shapes += f.contains("scope_mm") ? 1 : 0;
  EXPECT_LE(shapes, static_cast<size_t>(kSeriesMaxShapeFrames) + 1);
  EXPECT_GE(shapes, static_cast<size_t>(kSeriesMaxShapeFrames) / 2);
  EXPECT_EQ(frames[0]["t_s"], 0.0);
  EXPECT_TRUE(frames[0].contains("scope_mm"));
  EXPECT_NEAR(frames.back()["t_s"].get<double>(), 600.0, 1e-9);
  EXPECT_TRUE(frames.back().contains("scope_mm"));
  EXPECT_LT(series.dump().size(), patient_db::kMaxSessionSeriesBytes);
  // Frames stay in time order.
  for (size_t i = 1; i < frames.size(); ++i) {
    ASSERT_LT(frames[i - 1]["t_s"].get<double>(), frames[i]["t_s"].get<double>());
  }
}

TEST_F(WebSeriesTest, TheSessionShowsTheLessonVerdictAndEachCriterion) {
  ves::v1::SessionRecord record = Scripted(2.0);
  record.set_lesson_id("web-lesson");
  StoreWithoutSeries(record);
  // Not judged yet.
  json verdict = LessonVerdictJson(server_.store(), record);
  EXPECT_EQ(verdict["status"], "pending");
  patient_db::LessonVerdictRow row;
  row.session_uuid = record.uuid();
  row.trainee_id = "t1";
  row.curriculum_id = "web-curriculum";
  row.lesson_id = "web-lesson";
  row.passed = false;
  row.score = 61.5;
  row.judged_unix_ms = 1'700'000'100'000;
  row.detail = "pain_s 0.4 <= 10: ok\ntime_to_cecum_s 240 <= 180: FAILED\nreplayed 2 s";
  ASSERT_TRUE(server_.store().PutLessonVerdict(row).ok());
  const HttpResult r = Get("/api/v1/sessions/" + record.uuid(), supervisor_);
  ASSERT_EQ(r.status, 200) << r.body;
  verdict = json::parse(r.body)["lesson_verdict"];
  EXPECT_EQ(verdict["status"], "failed");
  EXPECT_EQ(verdict["lesson_id"], "web-lesson");
  EXPECT_EQ(verdict["judged_unix_ms"], 1'700'000'100'000);
  ASSERT_EQ(verdict["checks"].size(), 3u) << verdict.dump();
  EXPECT_EQ(verdict["checks"][0], (json{{"text", "pain_s 0.4 <= 10"}, {"passed", true}}));
  EXPECT_EQ(verdict["checks"][1],
            (json{{"text", "time_to_cecum_s 240 <= 180"}, {"passed", false}}));
  EXPECT_EQ(verdict["checks"][2], (json{{"text", "replayed 2 s"}, {"passed", nullptr}}));
}

}  // namespace
}  // namespace ves::server::testing
