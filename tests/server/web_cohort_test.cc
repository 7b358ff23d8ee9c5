// Proficiency, cohorts and exports over the HTTP API (docs/web.md,
// "Proficiency", "Cohorts", "Export") against a real server on loopback:
// the group page's figures per trainee with lesson attempts and practice runs
// apart, dates, curriculum progress and proficiency on the trainee list, the
// expert band of a curve, the group's CSV and the trainee report, with the
// institution rules and audit rows.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <nlohmann/json.hpp>
#include <random>
#include <sstream>
#include <thread>

#include "server/web_api.h"
#include "server/web_cohort.h"
#include "tests/integration/test_server.h"
#include "tests/server/web_client.h"
#include "tests/server/web_fixture.h"

namespace ves::server::testing {
namespace {

using nlohmann::json;
using patient_db::StoreRole;

constexpr int64_t kDay = 24 * 3600 * 1000;
constexpr int64_t kDay0 = 1'700'006'400'000;  // 2023-11-15T00:00:00Z

struct StoredRun {
  std::string uuid, trainee, lesson_id, operator_kind = "human";
  int64_t start = 0;
  double score = 0;
  bool completed = false;
  double time_to_cecum_s = 0, pain_s = 0, loop_s = -1, xray_s = -1;
  std::string institution = "north";
};

class WebCohortTest : public WebServerTest {
 protected:
  void SetUp() override {
    for (const char* id : {"t1", "t2", "t3", "x1"}) server_.AddTrainee(id, "north");
    server_.AddTrainee("s1", "south");
    auto& store = server_.store();
    for (const char* id : {"t1", "t2", "t3"}) ASSERT_TRUE(store.SetTraineeGroup(id, "g1").ok());
    ASSERT_TRUE(store.SetTraineeGroup("s1", "g1").ok());  // the same name in another institution
    // Curriculum c1 of two lessons, one pass each, assigned to the group.
    v1::Curriculum c;
    c.set_curriculum_id("c1");
    c.set_title("Basics");
    for (const char* id : {"l1", "l2"}) {
      v1::Lesson* l = c.add_lessons();
      l->set_lesson_id(id);
      l->set_title(std::string("Lesson ") + id);
      l->mutable_case_ref()->set_case_id("standard-adult");
      l->set_required_passes(1);
    }
    patient_db::CurriculumRow row;
    row.curriculum_id = "c1";
    row.institution = "north";
    row.title = "Basics";
    row.lesson_ids = {"l1", "l2"};
    row.created_by = "tok";
    row.created_unix_ms = 1;
    row.body = c.SerializeAsString();
    row.body_sha256_hex = Sha256Hex(row.body);
    ASSERT_TRUE(store.PutCurriculum(row).ok());
    ASSERT_TRUE(store.AddAssignment({"c1", true, "g1", "north", "tok", 1}).ok());

    // Stored as the upload path would (the judge scans only at start, so
    // these lesson sessions keep the verdicts written here).
    runs_ = {
        // t1: two practice runs, two passed lessons.
        {"p1", "t1", "", "human", kDay0, 60, true, 200, 5, 10, 3},
        {"p2", "t1", "", "human", kDay0 + kDay, 70, false, 0, 9, -1, 1},
        {"a1", "t1", "l1", "human", kDay0 + 2 * kDay, 80, true, 150, 2, 4, 0},
        {"a2", "t1", "l2", "human", kDay0 + 3 * kDay, 85, true, 170, 4, 6, 0},
        // t2: l1 failed then passed.
        {"b1", "t2", "l1", "human", kDay0 + kDay, 40, false, 0, 30, 20, 5},
        {"b2", "t2", "l1", "human", kDay0 + 2 * kDay, 75, true, 260, 12, 8, 2},
        // The scripted expert's runs of the case (x1, not in the group),
        // a novice's, and another institution's expert.
        {"e1", "x1", "", "expert", kDay0, 90, true, 120, 0, 1, 0},
        {"e2", "x1", "", "expert", kDay0 + kDay, 95, true, 110, 1, 2, 0},
        {"n1", "x1", "", "novice", kDay0, 5, false, 0, 60, 50, 0},
        {"e3", "s1", "", "expert", kDay0, 10, true, 400, 50, 40, 0, "south"},
    };
    patient_db::WriteBatch batch;
    for (const StoredRun& r : runs_) {
      patient_db::SessionRow s;
      s.uuid = Uuid(r.uuid);
      s.trainee_id = r.trainee;
      s.institution = r.institution;
      s.case_id = "standard-adult";
      s.case_version = 1;
      s.station_id = "station-1";
      s.start_unix_ms = r.start;
      s.end_unix_ms = r.start + 300'000;
      s.outcome = r.completed ? v1::OUTCOME_CECUM_REACHED : v1::OUTCOME_TIMED_OUT;
      s.completed = r.completed;
      s.time_to_cecum_s = r.time_to_cecum_s;
      s.pain_s = r.pain_s;
      s.score = r.score;
      s.operator_kind = r.operator_kind;
      s.loop_s = r.loop_s;
      s.xray_s = r.xray_s;
      s.lesson_id = r.lesson_id;
      s.body = "body of " + r.uuid;
      s.body_sha256_hex = Sha256Hex(s.body);
      s.stored_unix_ms = r.start;
      batch.sessions.push_back(s);
    }
    ASSERT_TRUE(store.CommitBatch(batch).ok());
    for (const StoredRun& r : runs_) {
      if (r.lesson_id.empty()) continue;
      const bool passed = r.uuid != "b1";
      ASSERT_TRUE(store
                      .PutLessonVerdict({Uuid(r.uuid), r.trainee, "c1", r.lesson_id, passed,
                                         r.score, r.start, r.start + 1000,
                                         passed ? "pain_s ok" : "pain_s 30 <= 20: FAILED", false})
                      .ok());
    }
    admin_ = server_.MakeToken(StoreRole::kAdmin, "north");
    supervisor_ = server_.MakeToken(StoreRole::kSupervisor, "north");
    south_supervisor_ = server_.MakeToken(StoreRole::kSupervisor, "south");
    station_ = server_.MakeToken(StoreRole::kStation, "north");
    trainee_t1_ = server_.MakeToken(StoreRole::kTrainee, "north", "t1");
  }

  // A uuid of the shape the server stores, named by a short tag.
  static std::string Uuid(const std::string& tag) {
    std::string hex;
    for (char c : tag) {
      char b[3];
      std::snprintf(b, sizeof b, "%02x", static_cast<unsigned char>(c));
      hex += b;
    }
    hex.resize(12, '0');
    return "00000000-0000-4000-8000-" + hex;
  }

  static const json& Trainee(const json& cohort, const std::string& id) {
    for (const json& t : cohort["trainees"]) {
      if (t["trainee_id"] == id) return t;
    }
    static const json none;
    ADD_FAILURE() << "no " << id << " in " << cohort.dump();
    return none;
  }

  std::vector<StoredRun> runs_;
  std::string admin_, supervisor_, south_supervisor_, station_, trainee_t1_;
};

TEST_F(WebCohortTest, CohortShowsEachTraineesFiguresWithPracticeApart) {
  const HttpResult r = Get("/api/v1/groups/g1/cohort", supervisor_);
  ASSERT_EQ(r.status, 200) << r.body;
  const json cohort = json::parse(r.body);
  EXPECT_EQ(cohort["group"], "g1");
  EXPECT_EQ(cohort["institution"], "north");
  ASSERT_EQ(cohort["trainees"].size(), 3u) << cohort.dump();  // not s1 of south's g1

  const json& t1 = Trainee(cohort, "t1");
  EXPECT_EQ(t1["lesson"]["attempts"], 2);
  EXPECT_EQ(t1["lesson"]["best_score"], 85.0);
  EXPECT_EQ(t1["lesson"]["last_score"], 85.0);
  EXPECT_EQ(t1["lesson"]["cecum_reached"], 2);
  EXPECT_EQ(t1["lesson"]["time_to_cecum_s"], 160.0);  // median of 150 and 170
  EXPECT_EQ(t1["lesson"]["pain_s"], 3.0);
  EXPECT_EQ(t1["lesson"]["loop_s"], 5.0);
  EXPECT_EQ(t1["lesson"]["xray_s"], 0.0);
  EXPECT_EQ(t1["practice"]["attempts"], 2);
  EXPECT_EQ(t1["practice"]["best_score"], 70.0);
  EXPECT_EQ(t1["practice"]["last_score"], 70.0);
  EXPECT_EQ(t1["practice"]["cecum_reached"], 1);
  EXPECT_EQ(t1["practice"]["time_to_cecum_s"], 200.0);  // only the run that reached it
  EXPECT_EQ(t1["practice"]["pain_s"], 7.0);
  EXPECT_EQ(t1["practice"]["loop_s"], 10.0);  // p2's loop time is not known
  EXPECT_EQ(t1["practice"]["xray_s"], 2.0);
  ASSERT_EQ(t1["curricula"].size(), 1u);
  EXPECT_EQ(t1["curricula"][0]["curriculum_id"], "c1");
  EXPECT_EQ(t1["curricula"][0]["title"], "Basics");
  EXPECT_EQ(t1["curricula"][0]["lessons"], 2);
  EXPECT_EQ(t1["curricula"][0]["passed"], 2);
  EXPECT_EQ(t1["curricula"][0]["proficient"], true);

  const json& t2 = Trainee(cohort, "t2");
  EXPECT_EQ(t2["lesson"]["attempts"], 2);
  EXPECT_EQ(t2["lesson"]["best_score"], 75.0);
  EXPECT_EQ(t2["lesson"]["last_score"], 75.0);
  EXPECT_EQ(t2["practice"]["attempts"], 0);
  EXPECT_TRUE(t2["practice"]["best_score"].is_null());
  EXPECT_EQ(t2["curricula"][0]["passed"], 1);
  EXPECT_EQ(t2["curricula"][0]["proficient"], false);

  const json& t3 = Trainee(cohort, "t3");
  EXPECT_EQ(t3["lesson"]["attempts"], 0);
  EXPECT_TRUE(t3["lesson"]["time_to_cecum_s"].is_null());
  EXPECT_EQ(t3["curricula"][0]["passed"], 0);
  EXPECT_TRUE(Audited("group.cohort", "group g1@north", "OK"));
}

TEST_F(WebCohortTest, CohortDatesNarrowTheFiguresNotTheProgress) {
  // Day 1 (included) to day 3 (excluded): p2 and a1 of t1, b1 and b2 of t2.
  const std::string range = "?from_unix_ms=" + std::to_string(kDay0 + kDay) +
                            "&to_unix_ms=" + std::to_string(kDay0 + 3 * kDay);
  const HttpResult r = Get("/api/v1/groups/g1/cohort" + range, supervisor_);
  ASSERT_EQ(r.status, 200) << r.body;
  const json cohort = json::parse(r.body);
  EXPECT_EQ(cohort["from_unix_ms"], kDay0 + kDay);
  const json& t1 = Trainee(cohort, "t1");
  EXPECT_EQ(t1["practice"]["attempts"], 1);
  EXPECT_EQ(t1["practice"]["best_score"], 70.0);
  EXPECT_EQ(t1["lesson"]["attempts"], 1);
  EXPECT_EQ(t1["lesson"]["last_score"], 80.0);
  EXPECT_EQ(t1["curricula"][0]["passed"], 2);  // progress counts every verdict
  EXPECT_EQ(Trainee(cohort, "t2")["lesson"]["attempts"], 2);
  const json later = json::parse(
      Get("/api/v1/groups/g1/cohort?from_unix_ms=" + std::to_string(kDay0 + 10 * kDay),
          supervisor_)
          .body);
  EXPECT_EQ(Trainee(later, "t1")["lesson"]["attempts"], 0);
}

TEST_F(WebCohortTest, GroupRoutesKeepTheInstitutionRules) {
  for (const std::string route : {"/api/v1/groups/g1/cohort", "/api/v1/groups/g1/sessions.csv"}) {
    EXPECT_EQ(Get(route).status, 401) << route;
    EXPECT_EQ(Get(route, "0123456789abcdef").status, 401) << route;
    EXPECT_EQ(Get(route + "?institution=north", south_supervisor_).status, 403) << route;
    EXPECT_EQ(Get(route, station_).status, 403) << route;
    EXPECT_EQ(Get(route, trainee_t1_).status, 403) << route;
    const HttpResult unknown = Get("/api/v1/groups/nobody/" + route.substr(route.rfind('/') + 1),
                                   supervisor_);
    EXPECT_EQ(unknown.status, 404) << unknown.body;
    const HttpResult backwards = Get(route + "?from_unix_ms=20&to_unix_ms=10", supervisor_);
    EXPECT_EQ(backwards.status, 400) << backwards.body;
    EXPECT_NE(backwards.body.find("to_unix_ms"), std::string::npos) << backwards.body;
    EXPECT_EQ(Get(route + "?from_unix_ms=yesterday", supervisor_).status, 400) << route;
    const HttpResult long_name = Get("/api/v1/groups/" + std::string(300, 'g') + "/cohort",
                                     supervisor_);
    EXPECT_EQ(long_name.status, 400) << long_name.body;
  }
  // South's supervisor sees south's g1 only; an admin may name north.
  const json south = json::parse(Get("/api/v1/groups/g1/cohort", south_supervisor_).body);
  ASSERT_EQ(south["trainees"].size(), 1u) << south.dump();
  EXPECT_EQ(south["trainees"][0]["trainee_id"], "s1");
  EXPECT_EQ(Get("/api/v1/groups/g1/cohort?institution=north", admin_).status, 200);
  EXPECT_TRUE(Audited("group.cohort", "group g1@north", "PERMISSION_DENIED"));
}

// Splits CSV text into rows of cells (RFC 4180 quotes; enough for a test).
std::vector<std::vector<std::string>> CsvRows(const std::string& text) {
  std::vector<std::vector<std::string>> rows(1);
  std::string cell;
  bool quoted = false;
  for (size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (quoted) {
      if (c == '"' && i + 1 < text.size() && text[i + 1] == '"') {
        cell += '"';
        ++i;
      } else if (c == '"') {
        quoted = false;
      } else {
        cell += c;
      }
    } else if (c == '"') {
      quoted = true;
    } else if (c == ',') {
      rows.back().push_back(cell);
      cell.clear();
    } else if (c == '\r' && i + 1 < text.size() && text[i + 1] == '\n') {
      rows.back().push_back(cell);
      cell.clear();
      rows.emplace_back();
      ++i;
    } else {
      cell += c;
    }
  }
  if (rows.back().empty()) rows.pop_back();
  return rows;
}

TEST_F(WebCohortTest, GroupSessionsExportAsCsvOneRowPerSession) {
  const HttpResult r = Get("/api/v1/groups/g1/sessions.csv", supervisor_);
  ASSERT_EQ(r.status, 200) << r.body;
  EXPECT_EQ(r.Header("content-type"), "text/csv; charset=utf-8");
  EXPECT_EQ(r.Header("content-disposition"),
            "attachment; filename=\"ves-sessions-group-g1.csv\"");
  const auto rows = CsvRows(r.body);
  ASSERT_EQ(rows.size(), 7u) << r.body;  // the header and t1's 4 and t2's 2 sessions
  EXPECT_EQ(rows[0], SessionsCsvColumns());
  const auto column = [&](const std::string& name) {
    const auto& c = SessionsCsvColumns();
    return static_cast<size_t>(std::find(c.begin(), c.end(), name) - c.begin());
  };
  std::vector<std::string> uuids;
  for (size_t i = 1; i < rows.size(); ++i) {
    ASSERT_EQ(rows[i].size(), SessionsCsvColumns().size()) << i;
    uuids.push_back(rows[i][column("session_uuid")]);
    EXPECT_NE(rows[i][column("trainee_id")], "x1");
  }
  // Oldest first: day 0 p1; day 1 b1, p2 (by uuid); day 2 a1, b2; day 3 a2.
  EXPECT_EQ(uuids, (std::vector<std::string>{Uuid("p1"), Uuid("b1"), Uuid("p2"), Uuid("a1"),
                                             Uuid("b2"), Uuid("a2")}));
  EXPECT_EQ(rows[2][column("lesson_verdict")], "failed");
  EXPECT_EQ(rows[2][column("lesson_checks")], "pain_s 30 <= 20: FAILED");
  EXPECT_EQ(rows[4][column("lesson_verdict")], "passed");
  EXPECT_EQ(rows[1][column("lesson_verdict")], "");
  EXPECT_EQ(rows[1][column("score")], "60.00");

  const std::string range = "?from_unix_ms=" + std::to_string(kDay0 + 2 * kDay) +
                            "&to_unix_ms=" + std::to_string(kDay0 + 3 * kDay);
  const auto day2 = CsvRows(Get("/api/v1/groups/g1/sessions.csv" + range, supervisor_).body);
  ASSERT_EQ(day2.size(), 3u);
  EXPECT_EQ(day2[1][column("session_uuid")], Uuid("a1"));
  EXPECT_EQ(day2[2][column("session_uuid")], Uuid("b2"));
  EXPECT_TRUE(Audited("session.export", "group g1@north", "OK"));
}

// An upload keeps the record's loop and X-ray time in its row: the cohort's
// figures and the CSV have them without reading the record.
TEST_F(WebCohortTest, AnUploadKeepsLoopAndXrayTimeForTheCohort) {
  PutSampleCase(server_.store(), "north");
  std::mt19937_64 rng(3);
  v1::SessionRecord record = MakeRecord(NewUuid(rng), "t3", 5);
  record.mutable_metrics()->set_loop_s(12.5);
  record.mutable_metrics()->set_xray_s(4.25);
  v1::UploadSessionResponse up;
  const grpc::Status s =
      UploadSession(server_.Client(server_.MakeToken(StoreRole::kStation, "north")), record, &up);
  ASSERT_TRUE(s.ok()) << s.error_message();
  const json cohort = json::parse(Get("/api/v1/groups/g1/cohort", supervisor_).body);
  EXPECT_EQ(Trainee(cohort, "t3")["practice"]["loop_s"], 12.5);
  EXPECT_EQ(Trainee(cohort, "t3")["practice"]["xray_s"], 4.25);
  const auto rows = CsvRows(Get("/api/v1/trainees/t3/sessions.csv", supervisor_).body);
  ASSERT_EQ(rows.size(), 2u);
  const auto& c = SessionsCsvColumns();
  const auto column = [&](const std::string& name) {
    return static_cast<size_t>(std::find(c.begin(), c.end(), name) - c.begin());
  };
  EXPECT_EQ(rows[1][column("loop_s")], "12.500");
  EXPECT_EQ(rows[1][column("xray_s")], "4.250");
}

TEST_F(WebCohortTest, TraineeListShowsCurriculumProgressAndProficiency) {
  const HttpResult r = Get("/api/v1/trainees", supervisor_);
  ASSERT_EQ(r.status, 200) << r.body;
  std::map<std::string, json> curricula;
  const json list = json::parse(r.body);
  for (const json& t : list["trainees"]) curricula[t["trainee_id"]] = t["curricula"];
  ASSERT_EQ(curricula["t1"].size(), 1u) << curricula["t1"].dump();
  EXPECT_EQ(curricula["t1"][0]["passed"], 2);
  EXPECT_EQ(curricula["t1"][0]["lessons"], 2);
  EXPECT_EQ(curricula["t1"][0]["proficient"], true);
  EXPECT_EQ(curricula["t2"][0]["passed"], 1);
  EXPECT_EQ(curricula["t2"][0]["proficient"], false);
  EXPECT_TRUE(curricula["x1"].empty());  // nothing assigned: no curriculum, not proficient
}

TEST_F(WebCohortTest, CurveShowsTheScriptedExpertsBandOfTheCase) {
  const HttpResult r = Get("/api/v1/trainees/t1/curve", supervisor_);
  ASSERT_EQ(r.status, 200) << r.body;
  const json curve = json::parse(r.body);
  ASSERT_EQ(curve["cases"].size(), 1u);
  const json& band = curve["cases"][0]["expert_band"];
  EXPECT_EQ(band["runs"], 2) << band.dump();  // not the novice's, not south's expert
  EXPECT_EQ(band["score"], json::array({90.0, 95.0}));
  EXPECT_EQ(band["time_to_cecum_s"], json::array({110.0, 120.0}));
  EXPECT_EQ(band["pain_s"], json::array({0.0, 1.0}));
  EXPECT_EQ(band["loop_s"], json::array({1.0, 2.0}));
  // The lessons' case is the same: the same band on each lesson's curve.
  ASSERT_EQ(curve["lessons"].size(), 2u);
  EXPECT_EQ(curve["lessons"][0]["expert_band"], band);
  // Loop time now comes from the stored row (the bodies here are not records).
  EXPECT_EQ(curve["cases"][0]["points"][0]["loop_s"], 10.0);
  // South's expert alone makes south's band.
  const json south = json::parse(Get("/api/v1/trainees/s1/curve", south_supervisor_).body);
  EXPECT_EQ(south["cases"][0]["expert_band"]["runs"], 1);
  EXPECT_EQ(south["cases"][0]["expert_band"]["score"], json::array({10.0, 10.0}));
}

TEST_F(WebCohortTest, TraineeReportHasProgressFiguresAndSessions) {
  const HttpResult r = Get("/api/v1/trainees/t1/report", supervisor_);
  ASSERT_EQ(r.status, 200) << r.body;
  const json report = json::parse(r.body);
  EXPECT_EQ(report["trainee_id"], "t1");
  EXPECT_EQ(report["group"], "g1");
  EXPECT_EQ(report["institution"], "north");
  EXPECT_EQ(report["lesson"]["attempts"], 2);
  EXPECT_EQ(report["practice"]["attempts"], 2);
  ASSERT_EQ(report["curricula"].size(), 1u);
  EXPECT_EQ(report["curricula"][0]["proficient"], true);
  const json& lessons = report["curricula"][0]["lesson_progress"];
  ASSERT_EQ(lessons.size(), 2u);
  EXPECT_EQ(lessons[0]["lesson_id"], "l1");
  EXPECT_EQ(lessons[0]["title"], "Lesson l1");
  EXPECT_EQ(lessons[0]["passes"], 1);
  EXPECT_EQ(lessons[0]["completed"], true);
  ASSERT_EQ(report["sessions"].size(), 4u);
  EXPECT_EQ(report["sessions"][2]["uuid"], Uuid("a1"));
  EXPECT_EQ(report["sessions"][2]["verdict"], "passed");
  EXPECT_EQ(report["sessions"][0]["verdict"], "");
  EXPECT_EQ(report["sessions"][1]["loop_s"], nullptr);  // not known for p2
  EXPECT_EQ(report["sessions"][0]["xray_s"], 3.0);
  const std::string range = "?from_unix_ms=" + std::to_string(kDay0 + 3 * kDay);
  EXPECT_EQ(json::parse(Get("/api/v1/trainees/t1/report" + range, supervisor_).body)["sessions"]
                .size(),
            1u);
  // The export's read rules: the trainee's own, nobody else's.
  EXPECT_EQ(Get("/api/v1/trainees/t1/report", trainee_t1_).status, 200);
  EXPECT_EQ(Get("/api/v1/trainees/t2/report", trainee_t1_).status, 404);
  EXPECT_EQ(Get("/api/v1/trainees/t1/report", south_supervisor_).status, 404);
  EXPECT_EQ(Get("/api/v1/trainees/t1/report", station_).status, 403);
  EXPECT_EQ(Get("/api/v1/trainees/t1/report").status, 401);
  EXPECT_TRUE(Audited("session.export", "t1", "OK"));
}

}  // namespace
}  // namespace ves::server::testing
