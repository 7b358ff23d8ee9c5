// The supervisors' workflow over the HTTP API (docs/web.md, "Workflow")
// against a real server on loopback: trainees added, put in groups and given
// curricula; notes and the sign-off on a session; each with its role check
// (403 for read-only roles), CSRF refusal, field bounds (400 naming the
// field) and audit row, and the audit log filtered for them, newest first.
#include <gtest/gtest.h>

#include <chrono>
#include <nlohmann/json.hpp>
#include <thread>
#include <tuple>

#include "server/web_api.h"
#include "tests/integration/test_server.h"
#include "tests/server/web_client.h"
#include "tests/server/web_fixture.h"

namespace ves::server::testing {
namespace {

using nlohmann::json;
using patient_db::StoreRole;

constexpr char kSession[] = "00000000-0000-4000-8000-000000000001";
constexpr char kSouthSession[] = "00000000-0000-4000-8000-000000000002";

class WebWorkflowTest : public WebServerTest {
 protected:
  void SetUp() override {
    server_.AddTrainee("t1", "north");
    server_.AddTrainee("s1", "south");
    auto& store = server_.store();
    for (const auto& [curriculum, institution] :
         {std::pair{"c1", "north"}, std::pair{"c-south", "south"}}) {
      v1::Curriculum c;
      c.set_curriculum_id(curriculum);
      c.set_title("Basics");
      v1::Lesson* l = c.add_lessons();
      l->set_lesson_id(std::string("l-") + curriculum);
      l->mutable_case_ref()->set_case_id("standard-adult");
      l->set_required_passes(1);
      patient_db::CurriculumRow row;
      row.curriculum_id = curriculum;
      row.institution = institution;
      row.title = "Basics";
      row.lesson_ids = {l->lesson_id()};
      row.created_by = "tok";
      row.created_unix_ms = 1;
      row.body = c.SerializeAsString();
      row.body_sha256_hex = Sha256Hex(row.body);
      ASSERT_TRUE(store.PutCurriculum(row).ok());
    }
    patient_db::WriteBatch batch;
    for (const auto& [uuid, trainee, institution] :
         {std::tuple{kSession, "t1", "north"}, std::tuple{kSouthSession, "s1", "south"}}) {
      patient_db::SessionRow s;
      s.uuid = uuid;
      s.trainee_id = trainee;
      s.institution = institution;
      s.case_id = "standard-adult";
      s.case_version = 1;
      s.station_id = "station-1";
      s.start_unix_ms = 1'700'000'000'000;
      s.end_unix_ms = s.start_unix_ms + 300'000;
      s.body = std::string("body of ") + uuid;
      s.body_sha256_hex = Sha256Hex(s.body);
      s.stored_unix_ms = s.end_unix_ms;
      batch.sessions.push_back(s);
    }
    ASSERT_TRUE(store.CommitBatch(batch).ok());
    admin_ = server_.MakeToken(StoreRole::kAdmin, "north");
    supervisor_ = server_.MakeToken(StoreRole::kSupervisor, "north");
    south_supervisor_ = server_.MakeToken(StoreRole::kSupervisor, "south");
    station_ = server_.MakeToken(StoreRole::kStation, "north");
    trainee_t1_ = server_.MakeToken(StoreRole::kTrainee, "north", "t1");
  }

  static std::string ErrorOf(const HttpResult& r) { return ErrorMessageOf(r); }

  // The audit rows of `action` as the API lists them (newest first), once
  // the group commit has written at least `at_least`.
  json AuditOf(const std::string& action, size_t at_least, const std::string& more = "") {
    json entries;
    for (int i = 0; i < 100; ++i) {
      const HttpResult r = Get("/api/v1/audit?action=" + action + more, admin_);
      EXPECT_EQ(r.status, 200) << r.body;
      entries = json::parse(r.body)["entries"];
      if (entries.size() >= at_least) break;
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
    return entries;
  }
  std::string admin_, supervisor_, south_supervisor_, station_, trainee_t1_;
};

TEST_F(WebWorkflowTest, ASupervisorAddsATraineePutsThemInAGroupAndAssignsACurriculum) {
  const auto [cookie, csrf] = SignIn(supervisor_);
  const Headers browser = {
      {"Cookie", cookie}, {"Content-Type", "application/json"}, {"X-CSRF-Token", csrf}};
  HttpResult r = HttpCall(port(), "POST", "/api/v1/trainees", browser,
                          R"({"trainee_id": "n1", "display_name": "New One"})");
  ASSERT_EQ(r.status, 200) << r.body;
  auto added = server_.store().GetTrainee("n1");
  ASSERT_TRUE(added.ok());
  EXPECT_EQ(added.value.institution, "north");  // the supervisor's own
  EXPECT_EQ(added.value.display_name, "New One");

  r = HttpCall(port(), "POST", "/api/v1/trainees/n1/group", browser, R"({"group": "g2"})");
  ASSERT_EQ(r.status, 200) << r.body;
  EXPECT_EQ(server_.store().GetTraineeGroup("n1").value, "g2");
  r = HttpCall(port(), "GET", "/api/v1/curricula", {{"Cookie", cookie}});
  ASSERT_EQ(r.status, 200) << r.body;
  const json curricula = json::parse(r.body)["curricula"];
  ASSERT_EQ(curricula.size(), 1u) << r.body;  // north's only
  EXPECT_EQ(curricula[0]["curriculum_id"], "c1");
  EXPECT_EQ(curricula[0]["lessons"], 1);

  r = HttpCall(port(), "POST", "/api/v1/assignments", browser,
               R"({"curriculum_id": "c1", "group": "g2"})");
  ASSERT_EQ(r.status, 200) << r.body;
  EXPECT_EQ(json::parse(r.body)["trainee_ids"], json::array({"n1"}));
  r = HttpCall(port(), "POST", "/api/v1/assignments", browser,
               R"({"curriculum_id": "c1", "trainee_id": "t1"})");
  ASSERT_EQ(r.status, 200) << r.body;

  // The trainee list reads them back: group, and progress in the curriculum.
  const json list = json::parse(Get("/api/v1/trainees", supervisor_).body);
  bool seen = false;
  for (const json& t : list["trainees"]) {
    if (t["trainee_id"] != "n1") continue;
    seen = true;
    EXPECT_EQ(t["display_name"], "New One");
    EXPECT_EQ(t["group"], "g2");
    ASSERT_EQ(t["curricula"].size(), 1u) << t.dump();
    EXPECT_EQ(t["curricula"][0]["curriculum_id"], "c1");
  }
  EXPECT_TRUE(seen) << list.dump();
  EXPECT_EQ(server_.store().ListAssignments("t1").value.size(), 1u);

  EXPECT_TRUE(Audited("trainee.add", "n1", "OK"));
  EXPECT_TRUE(Audited("trainee.group", "n1", "OK"));
  EXPECT_TRUE(Audited("curriculum.assign", "c1 group g2", "OK"));
  EXPECT_TRUE(Audited("curriculum.assign", "c1 trainee t1", "OK"));

  // Another institution stays out of reach: 403 naming it, or absent.
  r = Post("/api/v1/trainees", supervisor_, {{"trainee_id", "n2"}, {"institution", "south"}});
  EXPECT_EQ(r.status, 403) << r.body;
  EXPECT_FALSE(server_.store().GetTrainee("n2").ok());
  r = Post("/api/v1/assignments", supervisor_, {{"curriculum_id", "c-south"}, {"group", "g2"}});
  EXPECT_EQ(r.status, 404) << r.body;
  r = Post("/api/v1/trainees/s1/group", supervisor_, {{"group", "g2"}});
  EXPECT_EQ(r.status, 404) << r.body;
  EXPECT_EQ(server_.store().GetTraineeGroup("s1").value, "");
}

TEST_F(WebWorkflowTest, ASupervisorWritesNotesAndSignsASessionOffOnce) {
  const std::string notes = std::string("/api/v1/sessions/") + kSession + "/notes";
  const std::string sign_off = std::string("/api/v1/sessions/") + kSession + "/sign-off";
  HttpResult r = Get(notes, supervisor_);
  ASSERT_EQ(r.status, 200) << r.body;
  EXPECT_EQ(json::parse(r.body)["notes"], json::array());
  EXPECT_TRUE(json::parse(r.body)["sign_off"].is_null());
  EXPECT_TRUE(json::parse(r.body)["can_write"].get<bool>());

  const std::string first = "Loop at the sigmoid: <b>withdraw</b> & straighten.\nThen torque.";
  r = Post(notes, supervisor_, {{"text", first}});
  ASSERT_EQ(r.status, 200) << r.body;
  EXPECT_EQ(json::parse(r.body)["text"], first);
  EXPECT_EQ(json::parse(r.body)["author_label"], "supervisor@north");
  ASSERT_EQ(Post(notes, admin_, {{"text", "second"}}).status, 200);

  r = Post(sign_off, supervisor_, json::object());
  ASSERT_EQ(r.status, 200) << r.body;
  const json signed_off = json::parse(r.body);
  EXPECT_EQ(signed_off["signed_by_label"], "supervisor@north");
  EXPECT_GT(signed_off["signed_unix_ms"].get<int64_t>(), 0);
  r = Post(sign_off, admin_, json::object());
  EXPECT_EQ(r.status, 409) << r.body;
  EXPECT_NE(ErrorOf(r).find("already signed off by supervisor@north"), std::string::npos) << r.body;

  // Read back by the session page (the trainee too, who may not write) and
  // by the trainee's list of sessions.
  for (const std::string& reader : {supervisor_, trainee_t1_}) {
    r = Get(notes, reader);
    ASSERT_EQ(r.status, 200) << r.body;
    const json j = json::parse(r.body);
    ASSERT_EQ(j["notes"].size(), 2u) << r.body;
    EXPECT_EQ(j["notes"][0]["text"], first);  // oldest first, as written
    EXPECT_EQ(j["notes"][1]["text"], "second");
    EXPECT_EQ(j["notes"][1]["author_label"], "admin@north");
    EXPECT_EQ(j["sign_off"], signed_off);
    EXPECT_EQ(j["can_write"].get<bool>(), reader == supervisor_);
  }
  EXPECT_EQ(r.body.find("<b>"), std::string::npos) << "markup is escaped in the JSON";
  r = Get("/api/v1/trainees/t1/sign-offs", supervisor_);
  ASSERT_EQ(r.status, 200) << r.body;
  EXPECT_EQ(json::parse(r.body)["sign_offs"], json::array({signed_off}));

  // Another institution's supervisor: as if there were no such session.
  EXPECT_EQ(Get(notes, south_supervisor_).status, 404);
  EXPECT_EQ(Post(notes, south_supervisor_, {{"text", "x"}}).status, 404);
  EXPECT_EQ(Get("/api/v1/trainees/t1/sign-offs", south_supervisor_).status, 404);
  EXPECT_EQ(Post(std::string("/api/v1/sessions/") + kSouthSession + "/sign-off", supervisor_,
                 json::object())
                .status,
            404);
  EXPECT_FALSE(server_.store().GetSessionSignOff(kSouthSession).ok());

  EXPECT_TRUE(Audited("session.note", kSession, "OK"));
  EXPECT_TRUE(Audited("session.sign_off", kSession, "OK"));
  EXPECT_TRUE(Audited("session.sign_off", kSession, "ALREADY_EXISTS"));
  EXPECT_TRUE(Audited("session.note", kSession, "NOT_FOUND"));  // the south supervisor's try
}

TEST_F(WebWorkflowTest, ReadOnlyRolesGet403AndWriteNothing) {
  const std::string session = std::string("/api/v1/sessions/") + kSession;
  for (const std::string& token : {station_, trainee_t1_}) {
    EXPECT_EQ(Post(session + "/notes", token, {{"text", "mine"}}).status, 403);
    EXPECT_EQ(Post(session + "/sign-off", token, json::object()).status, 403);
    EXPECT_EQ(Post("/api/v1/trainees/t1/group", token, {{"group", "g9"}}).status, 403);
    EXPECT_EQ(
        Post("/api/v1/assignments", token, {{"curriculum_id", "c1"}, {"trainee_id", "t1"}}).status,
        403);
    EXPECT_EQ(Post("/api/v1/trainees", token, {{"trainee_id", "v1"}}).status, 403);
  }
  EXPECT_TRUE(server_.store().ListSessionNotes(kSession, 10).value.empty());
  EXPECT_FALSE(server_.store().GetSessionSignOff(kSession).ok());
  EXPECT_EQ(server_.store().GetTraineeGroup("t1").value, "");
  EXPECT_TRUE(server_.store().ListAssignments("t1").value.empty());
  EXPECT_FALSE(server_.store().GetTrainee("v1").ok());
  // The station may not read notes either (not a reader of trainees' records).
  EXPECT_EQ(Get(session + "/notes", station_).status, 403);
  EXPECT_TRUE(Audited("session.note", kSession, "PERMISSION_DENIED"));
  EXPECT_TRUE(Audited("session.sign_off", kSession, "PERMISSION_DENIED"));
  EXPECT_TRUE(Audited("trainee.group", "t1", "PERMISSION_DENIED"));
  EXPECT_TRUE(Audited("curriculum.assign", "c1 trainee t1", "PERMISSION_DENIED"));
  EXPECT_TRUE(Audited("trainee.add", "v1", "PERMISSION_DENIED"));
}

TEST_F(WebWorkflowTest, BadFieldsGet400NamingTheField) {
  const std::string notes = std::string("/api/v1/sessions/") + kSession + "/notes";
  const auto expect_400 = [&](const HttpResult& r, const std::string& field) {
    EXPECT_EQ(r.status, 400) << r.body;
    EXPECT_EQ(ErrorOf(r).rfind(field, 0), 0u) << "names " << field << ": " << r.body;
  };
  expect_400(Post(notes, supervisor_, {{"text", std::string(2001, 'x')}}), "text");
  expect_400(Post(notes, supervisor_, {{"text", ""}}), "text");
  expect_400(Post(notes, supervisor_, {{"text", std::string("bell\x07")}}), "text");
  expect_400(Post(notes, supervisor_, {{"text", 5}}), "text");
  expect_400(Post(notes, supervisor_, {{"text", "ok"}, {"mood", "x"}}), "body");
  expect_400(Post(std::string("/api/v1/sessions/") + kSession + "/sign-off", supervisor_,
                  {{"when", "now"}}),
             "body");
  expect_400(Post("/api/v1/trainees/t1/group", supervisor_, {{"group", std::string(129, 'g')}}),
             "group");
  expect_400(Post("/api/v1/trainees/t1/group", supervisor_, json::object()), "group");
  expect_400(Post("/api/v1/assignments", supervisor_,
                  {{"curriculum_id", "c1"}, {"trainee_id", "t1"}, {"group", "g"}}),
             "body");
  expect_400(Post("/api/v1/assignments", supervisor_, {{"trainee_id", "t1"}}), "curriculum_id");
  expect_400(Post("/api/v1/assignments", supervisor_,
                  {{"curriculum_id", "c1"}, {"trainee_id", std::string("a\nb")}}),
             "trainee_id");
  const HttpResult name = Post("/api/v1/trainees", supervisor_,
                               {{"trainee_id", "n3"}, {"display_name", std::string(300, 'n')}});
  EXPECT_EQ(name.status, 400) << name.body;
  EXPECT_NE(ErrorOf(name).find("display_name"), std::string::npos) << name.body;
  // A note at the bound is kept whole; nothing refused was stored.
  ASSERT_EQ(Post(notes, supervisor_, {{"text", std::string(2000, 'y')}}).status, 200);
  const auto stored = server_.store().ListSessionNotes(kSession, 10).value;
  ASSERT_EQ(stored.size(), 1u);
  EXPECT_EQ(stored[0].text, std::string(2000, 'y'));
  EXPECT_EQ(server_.store().GetTraineeGroup("t1").value, "");
  EXPECT_FALSE(server_.store().GetTrainee("n3").ok());
}

TEST_F(WebWorkflowTest, BrowserWritesWithoutTheCsrfTokenAreRefused) {
  const auto [cookie, csrf] = SignIn(supervisor_);
  const std::string session = std::string("/api/v1/sessions/") + kSession;
  const std::vector<std::pair<std::string, std::string>> writes = {
      {session + "/notes", R"({"text": "forged"})"},
      {session + "/sign-off", "{}"},
      {"/api/v1/trainees/t1/group", R"({"group": "forged"})"},
      {"/api/v1/assignments", R"({"curriculum_id": "c1", "trainee_id": "t1"})"},
      {"/api/v1/trainees", R"({"trainee_id": "forged"})"}};
  for (const auto& [target, body] : writes) {
    for (const std::string& token : {std::string(), std::string(64, 'a')}) {
      Headers h = {{"Cookie", cookie}, {"Content-Type", "application/json"}};
      if (!token.empty()) h.emplace_back("X-CSRF-Token", token);
      const HttpResult r = HttpCall(port(), "POST", target, h, body);
      EXPECT_EQ(r.status, 403) << target << ": " << r.body;
      EXPECT_NE(ErrorOf(r).find("CSRF"), std::string::npos) << target << ": " << r.body;
    }
  }
  EXPECT_TRUE(server_.store().ListSessionNotes(kSession, 10).value.empty());
  EXPECT_FALSE(server_.store().GetSessionSignOff(kSession).ok());
  EXPECT_EQ(server_.store().GetTraineeGroup("t1").value, "");
  EXPECT_TRUE(server_.store().ListAssignments("t1").value.empty());
  EXPECT_FALSE(server_.store().GetTrainee("forged").ok());
  // With the token the same note goes through.
  const HttpResult ok =
      HttpCall(port(), "POST", session + "/notes",
               {{"Cookie", cookie}, {"Content-Type", "application/json"}, {"X-CSRF-Token", csrf}},
               R"({"text": "with the token"})");
  EXPECT_EQ(ok.status, 200) << ok.body;
}

TEST_F(WebWorkflowTest, EveryRouteAnswers401WithoutAToken) {
  const std::string session = std::string("/api/v1/sessions/") + kSession;
  for (const std::string& target : std::vector<std::string>{session + "/notes", "/api/v1/curricula",
                                                            "/api/v1/trainees/t1/sign-offs"}) {
    EXPECT_EQ(HttpCall(port(), "GET", target).status, 401) << target;
  }
  for (const auto& [target, body] : std::vector<std::pair<std::string, std::string>>{
           {session + "/notes", R"({"text": "x"})"},
           {session + "/sign-off", "{}"},
           {"/api/v1/trainees/t1/group", R"({"group": "g"})"},
           {"/api/v1/assignments", R"({"curriculum_id": "c1", "group": "g"})"}}) {
    const HttpResult r =
        HttpCall(port(), "POST", target, {{"Content-Type", "application/json"}}, body);
    EXPECT_EQ(r.status, 401) << target << ": " << r.body;
  }
  EXPECT_TRUE(server_.store().ListSessionNotes(kSession, 10).value.empty());
}

TEST_F(WebWorkflowTest, ASessionKeepsAtMostItsBoundOfNotes) {
  const std::string notes = std::string("/api/v1/sessions/") + kSession + "/notes";
  for (int i = 0; i < patient_db::kMaxSessionNotes; ++i) {
    ASSERT_EQ(Post(notes, supervisor_, {{"text", "note " + std::to_string(i)}}).status, 200) << i;
  }
  const HttpResult over = Post(notes, supervisor_, {{"text", "one more"}});
  EXPECT_EQ(over.status, 409) << over.body;
  EXPECT_NE(ErrorOf(over).find("100 notes"), std::string::npos) << over.body;
  const json j = json::parse(Get(notes, supervisor_).body);
  EXPECT_EQ(j["notes"].size(), static_cast<size_t>(patient_db::kMaxSessionNotes));
}

TEST_F(WebWorkflowTest, TheAuditLogListsTheWorkflowNewestFirstByActionActorAndDate) {
  const std::string notes = std::string("/api/v1/sessions/") + kSession + "/notes";
  for (int i = 0; i < 3; ++i) ASSERT_EQ(Post(notes, supervisor_, {{"text", "n"}}).status, 200);
  ASSERT_EQ(Post(notes, admin_, {{"text", "by the admin"}}).status, 200);
  ASSERT_EQ(Post("/api/v1/trainees/t1/group", supervisor_, {{"group", "g1"}}).status, 200);
  const json all = AuditOf("session.note", 4);
  ASSERT_EQ(all.size(), 4u) << all.dump();
  for (size_t i = 1; i < all.size(); ++i) {
    EXPECT_GT(all[i - 1]["id"].get<int64_t>(), all[i]["id"].get<int64_t>()) << "newest first";
  }
  for (const json& e : all) EXPECT_EQ(e["action"], "session.note");
  EXPECT_EQ(all[0]["actor_label"], "admin@north");
  // By actor (its label), paged two at a time.
  json page = json::parse(
      Get("/api/v1/audit?action=session.note&actor=supervisor@north&page_size=2", admin_).body);
  ASSERT_EQ(page["entries"].size(), 2u) << page.dump();
  ASSERT_FALSE(page["next_page_token"].get<std::string>().empty());
  json rest = json::parse(Get("/api/v1/audit?action=session.note&actor=supervisor@north"
                              "&page_size=2&page_token=" +
                                  page["next_page_token"].get<std::string>(),
                              admin_)
                              .body);
  ASSERT_EQ(rest["entries"].size(), 1u) << rest.dump();
  EXPECT_LT(rest["entries"][0]["id"].get<int64_t>(), page["entries"][1]["id"].get<int64_t>());
  // By date: nothing before the rows were written, all of them from then on.
  const int64_t first_at = all.back()["at_unix_ms"].get<int64_t>();
  EXPECT_EQ(AuditOf("session.note", 0, "&to_unix_ms=" + std::to_string(first_at)).size(), 0u);
  EXPECT_EQ(AuditOf("session.note", 4, "&from_unix_ms=" + std::to_string(first_at)).size(), 4u);
}

}  // namespace
}  // namespace ves::server::testing
