// The HTTP API and pages of ves-server (docs/web.md) against a real server
// on loopback: authentication on every route, the institution matrix of the
// gRPC tests, CSRF, cookie flags, HTML-safe JSON, limits, and a session's
// replay computed by the server from its input log.
#include "server/web_api.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <boost/asio/ip/tcp.hpp>
#include <cstdlib>
#include <fstream>
#include <nlohmann/json.hpp>
#include <random>
#include <sstream>
#include <thread>

#include "patient_db/case_bundle.h"
#include "server/http_server.h"
#include "server/session_check.h"
#include "station/training/case_run.h"
#include "tests/integration/test_server.h"
#include "tests/server/web_client.h"
#include "tests/server/web_fixture.h"

namespace ves::server::testing {
namespace {

using nlohmann::json;
using patient_db::StoreRole;

const char kXss[] = "<img src=x onerror=alert(1)>";
const char kXssPath[] = "%3Cimg%20src%3Dx%20onerror%3Dalert(1)%3E";

class WebApiTest : public WebServerTest {
 protected:
  void SetUp() override {
    server_.AddTrainee("t1", "north");
    server_.AddTrainee("t2", "north");
    server_.AddTrainee(kXss, "north");
    server_.AddTrainee("s1", "south");
    ASSERT_TRUE(server_.store().SetTraineeGroup("t1", "g1").ok());
    ASSERT_TRUE(server_.store().SetTraineeGroup("t2", "g1").ok());
    PutSampleCase(server_.store(), "north", {"south"});
    admin_ = server_.MakeToken(StoreRole::kAdmin, "north");
    supervisor_ = server_.MakeToken(StoreRole::kSupervisor, "north");
    south_supervisor_ = server_.MakeToken(StoreRole::kSupervisor, "south");
    station_ = server_.MakeToken(StoreRole::kStation, "north");
    south_station_ = server_.MakeToken(StoreRole::kStation, "south");
    trainee_t2_ = server_.MakeToken(StoreRole::kTrainee, "north", "t2");
    std::mt19937_64 rng(7);
    north_uuid_ = NewUuid(rng);
    south_uuid_ = NewUuid(rng);
    ves::v1::UploadSessionResponse r;
    ASSERT_TRUE(UploadSession(server_.Client(station_), MakeRecord(north_uuid_, "t1", 1), &r).ok());
    ASSERT_TRUE(
        UploadSession(server_.Client(south_station_), MakeRecord(south_uuid_, "s1", 2), &r).ok());
  }

  std::string admin_, supervisor_, south_supervisor_, station_, south_station_, trainee_t2_;
  std::string north_uuid_, south_uuid_;
};

const std::vector<std::string>& ApiGetRoutes() {
  static const std::vector<std::string> routes = {
      "/api/v1/me",
      "/api/v1/trainees",
      "/api/v1/trainees/t1/sessions",
      "/api/v1/trainees/t1/curve",
      "/api/v1/sessions/00000000-0000-4000-8000-000000000000",
      "/api/v1/sessions/00000000-0000-4000-8000-000000000000/replay",
      "/api/v1/sessions/00000000-0000-4000-8000-000000000000/series",
      "/api/v1/groups/g1/progress",
      "/api/v1/audit",
      "/api/v1/live",
      "/api/v1/stations"};
  return routes;
}

TEST_F(WebApiTest, HealthzAnswersWithoutAuthentication) {
  const HttpResult r = Get("/healthz");
  EXPECT_EQ(r.status, 200);
  EXPECT_EQ(json::parse(r.body)["status"], "ok");
}

TEST_F(WebApiTest, EveryApiRouteWithoutAuthenticationIs401) {
  for (const std::string& route : ApiGetRoutes()) {
    const HttpResult r = Get(route);
    EXPECT_EQ(r.status, 401) << route << ": " << r.body;
    EXPECT_EQ(json::parse(r.body)["error"]["code"], "UNAUTHENTICATED") << route;
    EXPECT_EQ(Get(route, "0123456789abcdef").status, 401) << route << " with an unknown token";
    EXPECT_EQ(HttpCall(port(), "GET", route, {{"Cookie", "ves_session=forged"}}).status, 401)
        << route << " with a forged cookie";
  }
  const HttpResult post = HttpCall(port(), "POST", "/api/v1/trainees",
                                   {{"Content-Type", "application/json"}}, R"({"trainee_id":"x"})");
  EXPECT_EQ(post.status, 401) << post.body;
  EXPECT_EQ(
      HttpCall(port(), "POST", "/api/v1/sign-out", {{"Content-Type", "application/json"}}, "{}")
          .status,
      401);
}

// The gRPC role matrix (tests/integration/role_matrix_test.cc) over HTTP:
// another institution's trainee or session answers as a missing one (404,
// its existence is not told); listing another institution is refused (403).
TEST_F(WebApiTest, InstitutionMatrixMirrorsGrpc) {
  EXPECT_EQ(Get("/api/v1/trainees/t1/curve", supervisor_).status, 200);
  EXPECT_EQ(Get("/api/v1/trainees/t1/sessions", supervisor_).status, 200);
  EXPECT_EQ(Get("/api/v1/sessions/" + north_uuid_, supervisor_).status, 200);
  for (const std::string& target :
       {std::string("/api/v1/trainees/s1/curve"), std::string("/api/v1/trainees/s1/sessions"),
        std::string("/api/v1/sessions/") + south_uuid_,
        std::string("/api/v1/sessions/") + south_uuid_ + "/replay"}) {
    const HttpResult foreign = Get(target, supervisor_);
    EXPECT_EQ(foreign.status, 404) << target << ": " << foreign.body;
    EXPECT_EQ(foreign.body.find("south"), std::string::npos)
        << "tells the institution: " << foreign.body;
  }
  // The same answer as for ids that do not exist at all.
  EXPECT_EQ(Get("/api/v1/trainees/nobody/curve", supervisor_).status, 404);
  EXPECT_EQ(Get("/api/v1/trainees?institution=south", supervisor_).status, 403);
  EXPECT_EQ(Get("/api/v1/groups/g1/progress?institution=south", supervisor_).status, 403);
  EXPECT_EQ(Get("/api/v1/trainees?institution=north", south_supervisor_).status, 403);
  EXPECT_EQ(Get("/api/v1/trainees/t1/curve", south_supervisor_).status, 404);
  // Roles: a trainee reads only their own records; a station no records;
  // only admins read the audit log.
  EXPECT_EQ(Get("/api/v1/trainees/t2/curve", trainee_t2_).status, 200);
  EXPECT_EQ(Get("/api/v1/trainees/t1/curve", trainee_t2_).status, 404);
  EXPECT_EQ(Get("/api/v1/trainees", trainee_t2_).status, 403);
  EXPECT_EQ(Get("/api/v1/trainees/t1/curve", station_).status, 403);
  EXPECT_EQ(Get("/api/v1/audit", supervisor_).status, 403);
  EXPECT_EQ(Get("/api/v1/audit", admin_).status, 200);
  // Admins reach every institution.
  EXPECT_EQ(Get("/api/v1/trainees?institution=south", admin_).status, 200);
  EXPECT_EQ(Get("/api/v1/sessions/" + south_uuid_, admin_).status, 200);
}

TEST_F(WebApiTest, HttpCallsWriteTheSameAuditRowsAsGrpc) {
  ASSERT_EQ(Get("/api/v1/trainees/t1/curve", supervisor_).status, 200);
  ASSERT_EQ(Get("/api/v1/trainees/s1/curve", supervisor_).status, 404);
  // Audit rows go through the group commit: wait until they are visible.
  json entries;
  for (int i = 0; i < 100; ++i) {
    entries = json::parse(Get("/api/v1/audit?limit=1000", admin_).body)["entries"];
    int curves = 0;
    for (const auto& e : entries) curves += e["action"] == "trainee.curve";
    if (curves >= 2) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  bool ok_row = false, refused_row = false;
  for (const auto& e : entries) {
    if (e["action"] != "trainee.curve") continue;
    ok_row |= e["target"] == "t1" && e["result"] == "OK" && e["role"] == "ROLE_SUPERVISOR";
    refused_row |= e["target"] == "s1" && e["result"].get<std::string>().rfind("NOT_FOUND", 0) == 0;
  }
  EXPECT_TRUE(ok_row) << entries.dump();
  EXPECT_TRUE(refused_row) << entries.dump();
}

TEST_F(WebApiTest, SignInSetsAStrictHttpOnlyCookieAndSignOutEndsIt) {
  HttpResult reply;
  const auto [cookie, csrf] = SignIn(supervisor_, &reply);
  const std::string set_cookie = reply.Header("set-cookie");
  EXPECT_NE(set_cookie.find("HttpOnly"), std::string::npos) << set_cookie;
  EXPECT_NE(set_cookie.find("SameSite=Strict"), std::string::npos) << set_cookie;
  EXPECT_NE(set_cookie.find("Max-Age="), std::string::npos) << set_cookie;
  EXPECT_NE(set_cookie.find("Path=/"), std::string::npos) << set_cookie;
  EXPECT_EQ(set_cookie.find("Secure"), std::string::npos) << "plain HTTP: " << set_cookie;
  EXPECT_EQ(csrf.size(), 64u);
  EXPECT_EQ(reply.body.find(supervisor_), std::string::npos) << "the token comes back";
  EXPECT_EQ(HttpCall(port(), "GET", "/api/v1/trainees", {{"Cookie", cookie}}).status, 200);
  // Sign-out needs the CSRF token too.
  EXPECT_EQ(HttpCall(port(), "POST", "/api/v1/sign-out",
                     {{"Cookie", cookie}, {"Content-Type", "application/json"}}, "{}")
                .status,
            403);
  const HttpResult out = HttpCall(
      port(), "POST", "/api/v1/sign-out",
      {{"Cookie", cookie}, {"Content-Type", "application/json"}, {"X-CSRF-Token", csrf}}, "{}");
  EXPECT_EQ(out.status, 200) << out.body;
  EXPECT_NE(out.Header("set-cookie").find("Max-Age=0"), std::string::npos);
  EXPECT_EQ(HttpCall(port(), "GET", "/api/v1/trainees", {{"Cookie", cookie}}).status, 401);
  // A wrong token signs nobody in.
  EXPECT_EQ(HttpCall(port(), "POST", "/api/v1/sign-in", {{"Content-Type", "application/json"}},
                     R"({"token":"0123"})")
                .status,
            401);
}

TEST_F(WebApiTest, SessionCookiesAreSecureOverHttps) {
  // Over HTTPS with the server's certificate (made here by openssl).
  const auto dir = MakeTempDir("web-tls");
  const std::string d = dir.string();
  ASSERT_EQ(std::system(("cd '" + d +
                         "' && openssl req -x509 -newkey ec -pkeyopt "
                         "ec_paramgen_curve:prime256v1 -nodes -keyout server.key -out server.pem "
                         "-days 2 -subj /CN=localhost >openssl.log 2>&1")
                            .c_str()),
            0);
  ServerOptions tls;
  tls.tls_cert_file = d + "/server.pem";
  tls.tls_key_file = d + "/server.key";
  tls.http_listen = "127.0.0.1:0";
  TestServer secure(tls);
  const std::string token = secure.MakeToken(StoreRole::kSupervisor, "north");
  const HttpResult r =
      HttpCall(secure.server().http_port(), "POST", "/api/v1/sign-in",
               {{"Content-Type", "application/json"}}, json{{"token", token}}.dump(), /*tls=*/true);
  ASSERT_EQ(r.status, 200) << r.body;
  EXPECT_NE(r.Header("set-cookie").find("; Secure"), std::string::npos) << r.Header("set-cookie");
  EXPECT_NE(r.Header("strict-transport-security").find("max-age"), std::string::npos);
  EXPECT_EQ(HttpCall(secure.server().http_port(), "GET", "/healthz", {}, "", true).status, 200);
  std::filesystem::remove_all(dir);
}

TEST_F(WebApiTest, StateChangingRequestsNeedTheCsrfToken) {
  const auto [cookie, csrf] = SignIn(admin_);
  const std::string body = R"({"trainee_id":"t9","display_name":"Nine"})";
  const HttpResult without =
      HttpCall(port(), "POST", "/api/v1/trainees",
               {{"Cookie", cookie}, {"Content-Type", "application/json"}}, body);
  EXPECT_EQ(without.status, 403) << without.body;
  EXPECT_NE(without.body.find("CSRF"), std::string::npos) << without.body;
  const HttpResult wrong = HttpCall(port(), "POST", "/api/v1/trainees",
                                    {{"Cookie", cookie},
                                     {"Content-Type", "application/json"},
                                     {"X-CSRF-Token", std::string(64, 'a')}},
                                    body);
  EXPECT_EQ(wrong.status, 403);
  EXPECT_FALSE(server_.store().GetTrainee("t9").ok()) << "added without a CSRF token";
  // A form post (no preflight across origins) is refused whatever it carries.
  EXPECT_EQ(HttpCall(port(), "POST", "/api/v1/trainees",
                     {{"Cookie", cookie},
                      {"Content-Type", "application/x-www-form-urlencoded"},
                      {"X-CSRF-Token", csrf}},
                     "trainee_id=t9")
                .status,
            415);
  const HttpResult with = HttpCall(
      port(), "POST", "/api/v1/trainees",
      {{"Cookie", cookie}, {"Content-Type", "application/json"}, {"X-CSRF-Token", csrf}}, body);
  EXPECT_EQ(with.status, 200) << with.body;
  EXPECT_TRUE(server_.store().GetTrainee("t9").ok());
  // Scripts with a bearer token carry no ambient credential: no CSRF token.
  EXPECT_EQ(HttpCall(port(), "POST", "/api/v1/trainees",
                     {{"Authorization", "Bearer " + admin_}, {"Content-Type", "application/json"}},
                     R"({"trainee_id":"t10"})")
                .status,
            200);
  // The role rule is the gRPC one: a supervisor adds trainees to their own
  // institution only, a station none.
  const auto add = [&](const std::string& token, const std::string& body) {
    return HttpCall(port(), "POST", "/api/v1/trainees",
                    {{"Authorization", "Bearer " + token}, {"Content-Type", "application/json"}},
                    body)
        .status;
  };
  EXPECT_EQ(add(supervisor_, R"({"trainee_id":"t11"})"), 200);
  EXPECT_EQ(server_.store().GetTrainee("t11").value.institution, "north");
  EXPECT_EQ(add(supervisor_, R"({"trainee_id":"t12","institution":"south"})"), 403);
  EXPECT_EQ(add(station_, R"({"trainee_id":"t13"})"), 403);
  EXPECT_FALSE(server_.store().GetTrainee("t12").ok());
  EXPECT_FALSE(server_.store().GetTrainee("t13").ok());
}

TEST_F(WebApiTest, MarkupInNamesComesBackJsonEscaped) {
  for (const std::string& target :
       {std::string("/api/v1/trainees"), std::string("/api/v1/trainees/") + kXssPath + "/curve"}) {
    const HttpResult r = Get(target, supervisor_);
    ASSERT_EQ(r.status, 200) << target << ": " << r.body;
    EXPECT_EQ(r.body.find('<'), std::string::npos) << target << ": " << r.body;
    EXPECT_EQ(r.body.find('>'), std::string::npos) << target << ": " << r.body;
    EXPECT_NE(r.body.find("\\u003cimg src=x onerror=alert(1)\\u003e"), std::string::npos)
        << target << ": " << r.body;
    EXPECT_EQ(r.Header("content-type"), "application/json");
    EXPECT_EQ(r.Header("x-content-type-options"), "nosniff");
  }
  const HttpResult sessions =
      Get(std::string("/api/v1/trainees/") + kXssPath + "/sessions", supervisor_);
  EXPECT_EQ(sessions.status, 200) << sessions.body;
  // And it decodes to the name as stored.
  const json list = json::parse(Get("/api/v1/trainees", supervisor_).body);
  bool found = false;
  for (const auto& t : list["trainees"]) found |= t["trainee_id"] == kXss;
  EXPECT_TRUE(found);
  // An error naming it is escaped as well.
  const HttpResult missing = Get(std::string("/api/v1/sessions/") + kXssPath, supervisor_);
  EXPECT_EQ(missing.body.find('<'), std::string::npos) << missing.body;
}

// Stations report with their uploads; the page's API shows an institution's
// own, with flags on health out of range, and is audited as a read.
TEST_F(WebApiTest, StationsShowTheirReportedHealthToTheirOwnInstitution) {
  std::mt19937_64 rng(11);
  auto record = MakeRecord(NewUuid(rng), "t1", 3);  // newer than SetUp's (seed 1)
  record.set_station_id(kXss);                      // a station named like markup
  record.set_software_version("0.1.0");
  auto* h = record.mutable_station_health();
  h->set_device("can:can0");
  h->set_loop_cycles(600'000);
  h->set_loop_cycle_p99_us(1500);  // over the 1000 us budget
  h->set_loop_budget_us(1000);
  h->set_hard_faults(1);
  ves::v1::UploadSessionResponse r;
  ASSERT_TRUE(UploadSession(server_.Client(station_), record, &r).ok());
  auto south = MakeRecord(NewUuid(rng), "s1", 4);
  south.set_station_id("south-station");
  ASSERT_TRUE(UploadSession(server_.Client(south_station_), south, &r).ok());

  const HttpResult got = Get("/api/v1/stations", supervisor_);
  ASSERT_EQ(got.status, 200) << got.body;
  EXPECT_EQ(got.body.find('<'), std::string::npos) << got.body;  // JSON-escaped markup
  EXPECT_EQ(got.body.find("south-station"), std::string::npos) << got.body;
  const json stations = json::parse(got.body)["stations"];
  ASSERT_EQ(stations.size(), 2u) << stations.dump();
  // By station id: the markup name sorts first ('<' < 's').
  EXPECT_EQ(stations[0]["station_id"], kXss);
  EXPECT_EQ(stations[0]["software_version"], "0.1.0");
  EXPECT_EQ(stations[0]["health"]["loop_cycle_p99_us"], 1500.0);
  EXPECT_EQ(stations[0]["health"]["hard_faults"], 1);
  EXPECT_EQ(stations[0]["health"]["loop_cycles"], 600'000);
  for (const auto& count : ves::server::kStationHealthCounts) {  // every counter, unset ones 0
    EXPECT_TRUE(stations[0]["health"].contains(count.name)) << count.name;
  }
  EXPECT_EQ(stations[0]["flags"], json::array({"loop_p99", "safe_state"}));
  // The session's page shows the health it was uploaded with, in the same
  // shape (numbers, not the proto's uint64 strings) and with the same flags.
  const HttpResult session = Get("/api/v1/sessions/" + record.uuid(), supervisor_);
  ASSERT_EQ(session.status, 200) << session.body;
  const json health = json::parse(session.body)["station_health"];
  EXPECT_EQ(health["loop_cycles"], 600'000) << health.dump();
  EXPECT_EQ(health["loop_cycle_p99_us"], 1500.0);
  EXPECT_EQ(health["device"], "can:can0");
  EXPECT_EQ(json::parse(session.body)["station_health_flags"],
            json::array({"loop_p99", "safe_state"}));
  const HttpResult plain = Get("/api/v1/sessions/" + south.uuid(), south_supervisor_);
  ASSERT_EQ(plain.status, 200) << plain.body;
  EXPECT_TRUE(json::parse(plain.body)["station_health"].is_null()) << plain.body;
  EXPECT_EQ(json::parse(plain.body)["station_health_flags"], json::array());
  // SetUp's upload carried no health: seen, not reported.
  EXPECT_EQ(stations[1]["station_id"], "station-1");
  EXPECT_TRUE(stations[1]["health"].is_null());
  EXPECT_EQ(stations[1]["flags"], json::array());
  EXPECT_GT(stations[1]["last_seen_unix_ms"].get<int64_t>(), 0);

  // Other institutions and other roles.
  EXPECT_EQ(Get("/api/v1/stations?institution=south", supervisor_).status, 403);
  EXPECT_EQ(Get("/api/v1/stations", trainee_t2_).status, 403);
  EXPECT_EQ(Get("/api/v1/stations", station_).status, 403);
  // South has its own "station-1" (SetUp's upload) beside "south-station":
  // stations are keyed by institution and id.
  const json south_view = json::parse(Get("/api/v1/stations", south_supervisor_).body);
  ASSERT_EQ(south_view["stations"].size(), 2u) << south_view.dump();
  EXPECT_EQ(south_view["stations"][0]["station_id"], "south-station");
  EXPECT_EQ(south_view["stations"][1]["station_id"], "station-1");
  EXPECT_EQ(south_view["stations"][1]["institution"], "south");
  EXPECT_EQ(south_view.dump().find("onerror"), std::string::npos) << south_view.dump();
  EXPECT_EQ(json::parse(Get("/api/v1/stations?institution=south", admin_).body)["stations"],
            south_view["stations"]);

  // Audited like the other reads: the supervisor's read and the refusals.
  bool read = false, refused = false;
  for (int i = 0; i < 100 && !(read && refused); ++i) {
    const json audit = json::parse(Get("/api/v1/audit?limit=1000", admin_).body);
    for (const auto& e : audit["entries"]) {
      if (e["action"] != "station.list") continue;
      read |= e["target"] == "north" && e["result"] == "OK" && e["role"] == "ROLE_SUPERVISOR";
      refused |= e["target"] == "south" &&
                 e["result"].get<std::string>().rfind("PERMISSION_DENIED", 0) == 0;
    }
    if (!(read && refused)) std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  EXPECT_TRUE(read);
  EXPECT_TRUE(refused);
}

TEST(StationHealthFlags, FlagWhatIsOutOfRange) {
  v1::StationHealth h;
  h.set_loop_budget_us(1000);
  EXPECT_TRUE(StationHealthFlags(h).empty());
  h.set_loop_cycle_p99_us(1000);  // at the budget: fine
  h.set_loop_cycles(10);
  EXPECT_TRUE(StationHealthFlags(h).empty());
  h.set_loop_cycle_p99_us(1001);
  EXPECT_EQ(StationHealthFlags(h), std::vector<std::string>{"loop_p99"});
  h.set_loop_cycle_p99_us(10);
  h.set_loop_overruns(1);
  h.set_transient_faults(1);
  h.set_can_malformed_frames(1);
  EXPECT_EQ(StationHealthFlags(h),
            (std::vector<std::string>{"overruns", "safe_state", "can_errors"}));
}

TEST_F(WebApiTest, BadInputGetsAClearJsonError) {
  const auto error_of = [](const HttpResult& r) {
    return json::parse(r.body)["error"]["message"].get<std::string>();
  };
  HttpResult r = Get("/api/v1/trainees?page_size=abc", supervisor_);
  EXPECT_EQ(r.status, 400);
  EXPECT_NE(error_of(r).find("page_size"), std::string::npos) << r.body;
  r = Get("/api/v1/trainees?page_size=99999999", supervisor_);
  EXPECT_EQ(r.status, 400);
  r = Get("/api/v1/trainees/%zz/curve", supervisor_);
  EXPECT_EQ(r.status, 400) << r.body;
  r = Get("/api/v1/trainees/" + std::string(300, 'x') + "/curve", supervisor_);
  EXPECT_EQ(r.status, 400) << r.body;  // the request limits of gRPC name the field
  EXPECT_NE(error_of(r).find("trainee_id"), std::string::npos) << r.body;
  r = Get("/api/v1/" + std::string(3000, 'x'), supervisor_);
  EXPECT_EQ(r.status, 414);
  r = Get("/api/v1/nothing-here", supervisor_);
  EXPECT_EQ(r.status, 404);
  EXPECT_NE(error_of(r).find("nothing-here"), std::string::npos);
  r = HttpCall(port(), "POST", "/api/v1/trainees",
               {{"Authorization", "Bearer " + admin_}, {"Content-Type", "application/json"}},
               "{not json");
  EXPECT_EQ(r.status, 400);
  EXPECT_NE(error_of(r).find("body"), std::string::npos) << r.body;
  r = HttpCall(port(), "POST", "/api/v1/sign-in", {{"Content-Type", "application/json"}},
               R"({"token": 5})");
  EXPECT_EQ(r.status, 400);
  // Oversized header and body: refused before any handler.
  const std::string big_header =
      "GET /healthz HTTP/1.1\r\nHost: x\r\nX-Big: " + std::string(kMaxHttpHeaderBytes + 10, 'a') +
      "\r\n\r\n";
  EXPECT_EQ(HttpRaw(port(), big_header).status, 431);
  const std::string big_body =
      "POST /api/v1/sign-in HTTP/1.1\r\nHost: x\r\nContent-Type: "
      "application/json\r\nContent-Length: " +
      std::to_string(kMaxHttpBodyBytes + 1) + "\r\n\r\n" + std::string(kMaxHttpBodyBytes + 1, ' ');
  EXPECT_EQ(HttpRaw(port(), big_body).status, 413);
  EXPECT_EQ(HttpRaw(port(), "NONSENSE\r\n\r\n").status, 400);
  // The server still answers.
  EXPECT_EQ(Get("/healthz").status, 200);
}

TEST_F(WebApiTest, PagesAreServedFromTheBinaryWithAStrictPolicy) {
  for (const std::string page :
       {"/", "/index.html", "/trainees.html", "/trainee.html", "/session.html", "/progress.html",
        "/audit.html", "/live.html", "/stations.html", "/group.html", "/report.html"}) {
    const HttpResult r = Get(page);
    EXPECT_EQ(r.status, 200) << page;
    EXPECT_EQ(r.Header("content-type"), "text/html; charset=utf-8") << page;
    EXPECT_NE(r.Header("content-security-policy").find("script-src 'self'"), std::string::npos);
    EXPECT_EQ(r.body.find("http://"), std::string::npos) << page << " loads from elsewhere";
    EXPECT_EQ(r.body.find("https://"), std::string::npos) << page << " loads from elsewhere";
  }
  const HttpResult chart = Get("/chart.js");
  EXPECT_EQ(chart.status, 200);
  EXPECT_NE(chart.body.find("Chart.js"), std::string::npos);
  for (const char* script : {"/common.js", "/sign_in.js", "/trainees.js", "/curves.js",
                             "/session.js", "/audit.js", "/stations.js", "/live.js", "/cohort.js",
                             "/workflow.js"}) {
    const HttpResult js = Get(script);
    EXPECT_EQ(js.status, 200) << script;
    EXPECT_EQ(js.body.find("innerHTML"), std::string::npos) << script << ": data must go in as text";
  }
  EXPECT_EQ(Get("/../etc/passwd").status, 404);
}

TEST(WebServerOptions, PlainHttpOffLoopbackIsRefused) {
  HttpServer server({"0.0.0.0:0", "", ""}, ServiceDeps{});
  try {
    server.Start();
    FAIL() << "plain HTTP on 0.0.0.0 was accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("loopback"), std::string::npos) << e.what();
  }
}

// A real session (a scripted operator on the sample case) uploaded as a
// station does: the server's replay from the input log ends where the
// recording run ended.
TEST_F(WebApiTest, ReplayIsComputedFromTheInputLogAndEndsAtTheFinalDepth) {
  ves::v1::SessionRecord record;
  double final_tip_arc_m = 0;
  int steps = 0;
  training::RunScriptedCase(
      SampleCase(), ves::v1::EndoscopeSpec(), {}, "expert", 2.0, 1'700'000'000'000, &record,
      [&](const training::InputSample&, const training::SessionRunner& runner) {
        final_tip_arc_m = runner.observation().tip_arc_m;
        ++steps;
      });
  record.set_trainee_id("t1");
  record.set_station_id("station-1");
  record.set_case_id(SampleCase().id());
  record.set_case_version(SampleCase().version());
  record.set_case_sha256_hex(patient_db::CasePayloadSha256Hex(SampleCase()));
  ves::v1::UploadSessionResponse up;
  const grpc::Status s = UploadSession(server_.Client(station_), record, &up);
  ASSERT_TRUE(s.ok()) << s.error_message();
  const HttpResult r = Get("/api/v1/sessions/" + record.uuid() + "/replay", supervisor_);
  ASSERT_EQ(r.status, 200) << r.body;
  const json replay = json::parse(r.body);
  const json& frames = replay["frames"];
  ASSERT_GT(frames.size(), 10u);
  EXPECT_NEAR(frames.back()["tip_arc_m"].get<double>(), final_tip_arc_m, 1e-9);
  EXPECT_NEAR(replay["final_tip_arc_m"].get<double>(), final_tip_arc_m, 1e-9);
  EXPECT_NEAR(frames.back()["t_s"].get<double>(), steps * record.input_log().dt_s(), 1e-6);
  EXPECT_GT(final_tip_arc_m, 0.0);
  EXPECT_TRUE(frames.back().contains("scope_mm"));
  EXPECT_TRUE(frames.back().contains("colon_mm"));
  EXPECT_GE(frames.back()["scope_mm"].size(), 2u);
  // The replay opens on the first step with its shapes (not an empty view
  // until the first shape sample), then runs at the series rate (10 Hz).
  EXPECT_NEAR(frames[0]["t_s"].get<double>(), record.input_log().dt_s(), 1e-9);
  ASSERT_TRUE(frames[0].contains("scope_mm")) << frames[0].dump();
  ASSERT_TRUE(frames[0].contains("colon_mm")) << frames[0].dump();
  EXPECT_GE(frames[0]["scope_mm"].size(), 1u);  // not in yet: the tip at the anus
  EXPECT_GE(frames[0]["colon_mm"].size(), 2u);
  EXPECT_NEAR(frames[1]["t_s"].get<double>(), 0.1, 1e-6);
  EXPECT_NEAR(frames[2]["t_s"].get<double>() - frames[1]["t_s"].get<double>(), 0.1, 1e-6);
  // The summary leaves out the bulky input log.
  const json summary = json::parse(Get("/api/v1/sessions/" + record.uuid(), supervisor_).body);
  EXPECT_FALSE(summary["record"].contains("input_log"));
  EXPECT_EQ(summary["record"]["trainee_id"], "t1");
  // A record without a usable log answers a clear refusal, not a crash.
  const HttpResult bad = Get("/api/v1/sessions/" + north_uuid_ + "/replay", supervisor_);
  EXPECT_EQ(bad.status, 409) << bad.body;
  EXPECT_NE(bad.body.find("cannot be replayed"), std::string::npos) << bad.body;
}

TEST_F(WebApiTest, LearningCurveHasOnePointPerSessionAndTheGroupMedian) {
  std::mt19937_64 rng(11);
  ves::v1::UploadSessionResponse up;
  for (int i = 0; i < 3; ++i) {
    ASSERT_TRUE(
        UploadSession(server_.Client(station_), MakeRecord(NewUuid(rng), "t2", 10 + i), &up).ok());
  }
  const HttpResult r = Get("/api/v1/trainees/t2/curve", supervisor_);
  ASSERT_EQ(r.status, 200) << r.body;
  const json curve = json::parse(r.body);
  ASSERT_EQ(curve["cases"].size(), 1u);
  const json& c = curve["cases"][0];
  EXPECT_EQ(c["points"].size(), 3u);
  EXPECT_EQ(c["points"][2]["attempt"], 3);
  EXPECT_EQ(curve["group"], "g1");
  // Group g1 is t1 (1 session) and t2 (3): attempt 1 has two scores, 2 and 3 one.
  ASSERT_EQ(c["group_median"].size(), 3u);
  const json t1 = json::parse(Get("/api/v1/trainees/t1/curve", supervisor_).body);
  const double t1_first = t1["cases"][0]["points"][0]["score"];
  const double t2_first = c["points"][0]["score"];
  EXPECT_NEAR(c["group_median"][0]["score"].get<double>(), 0.5 * (t1_first + t2_first), 1e-9);
  EXPECT_NEAR(c["points"][0]["time_to_cecum_s"].get<double>(), 210.0, 1e-9);
  const json list = json::parse(Get("/api/v1/trainees", supervisor_).body);
  for (const auto& t : list["trainees"]) {
    if (t["trainee_id"] == "t2") {
      EXPECT_EQ(t["sessions"], 3);
      EXPECT_GT(t["last_activity_unix_ms"].get<int64_t>(), 0);
      EXPECT_EQ(t["group"], "g1");
    }
  }
}

// A session that did not reach the cecum has no time to cecum on the curve
// (null, drawn as a gap and shown as a dash), not a time of 0 s.
TEST_F(WebApiTest, ACurvePointWithoutTheCecumHasNoTimeToCecum) {
  std::mt19937_64 rng(12);
  ves::v1::UploadSessionResponse up;
  auto timed_out = MakeRecord(NewUuid(rng), "t2", 20);
  timed_out.set_outcome(ves::v1::OUTCOME_TIMED_OUT);
  timed_out.mutable_metrics()->set_completed(false);
  timed_out.mutable_metrics()->clear_time_to_cecum_s();
  ASSERT_TRUE(UploadSession(server_.Client(station_), timed_out, &up).ok());
  ASSERT_TRUE(
      UploadSession(server_.Client(station_), MakeRecord(NewUuid(rng), "t2", 21), &up).ok());
  const json curve = json::parse(Get("/api/v1/trainees/t2/curve", supervisor_).body);
  ASSERT_EQ(curve["cases"].size(), 1u);
  const json& points = curve["cases"][0]["points"];
  ASSERT_EQ(points.size(), 2u);
  EXPECT_TRUE(points[0]["time_to_cecum_s"].is_null()) << points.dump();
  EXPECT_FALSE(points[0]["completed"].get<bool>());
  EXPECT_NEAR(points[1]["time_to_cecum_s"].get<double>(), 221.0, 1e-9);
}

// A lesson the scripted expert passes in 3 s on the sample case: after the
// server's judge passes it, the curve has that lesson with its point and
// pass line (the lesson id must come back from the store's listing).
TEST_F(WebApiTest, LearningCurveShowsALessonAfterItIsPassed) {
  ves::v1::Curriculum c;
  c.set_curriculum_id("web-lessons");
  c.set_title("Web lessons");
  ves::v1::Lesson* lesson = c.add_lessons();
  lesson->set_lesson_id("web-first-seconds");
  lesson->set_title("The first seconds");
  lesson->mutable_case_ref()->set_case_id(SampleCase().id());
  lesson->mutable_aids()->set_fluoroscopy_allowed(true);
  lesson->mutable_aids()->set_wireframe_allowed(true);
  lesson->set_time_limit_s(3);
  lesson->mutable_pass()->set_max_damage_events(0);
  lesson->mutable_pass()->set_max_pain_s(30);
  lesson->set_required_passes(1);
  auto lessons = ves::v1::Lessons::NewStub(MakeClientChannel(server_.Client(supervisor_)));
  ves::v1::CreateCurriculumRequest create;
  *create.mutable_curriculum() = c;
  ves::v1::CreateCurriculumResponse created;
  {
    grpc::ClientContext ctx;
    PrepareContext(&ctx, server_.Client(supervisor_));
    const grpc::Status s = lessons->CreateCurriculum(&ctx, create, &created);
    ASSERT_TRUE(s.ok()) << s.error_message();
  }
  const ves::v1::Lesson& stored_lesson = created.curriculum().lessons(0);
  ves::v1::SessionRecord record;
  training::RunScriptedCase(SampleCase(), stored_lesson.scope(), {}, "expert", 3.0,
                            1'700'000'000'000, &record);
  record.set_trainee_id("t2");
  record.set_station_id("station-1");
  record.set_case_id(SampleCase().id());
  record.set_case_version(SampleCase().version());
  record.set_case_sha256_hex(patient_db::CasePayloadSha256Hex(SampleCase()));
  record.set_lesson_id(stored_lesson.lesson_id());
  ves::v1::UploadSessionResponse up;
  const grpc::Status s = UploadSession(server_.Client(station_), record, &up);
  ASSERT_TRUE(s.ok()) << s.error_message();
  // The judge replays it in the background.
  patient_db::StoreResult<patient_db::LessonVerdictRow> verdict;
  for (int i = 0; i < 600; ++i) {
    verdict = server_.store().GetLessonVerdict(record.uuid());
    if (verdict.ok()) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  ASSERT_TRUE(verdict.ok()) << "no verdict: " << verdict.status.message;
  ASSERT_TRUE(verdict.value.passed) << verdict.value.detail;

  const HttpResult r = Get("/api/v1/trainees/t2/curve", supervisor_);
  ASSERT_EQ(r.status, 200) << r.body;
  const json curve = json::parse(r.body);
  ASSERT_EQ(curve["lessons"].size(), 1u) << curve.dump();
  const json& l = curve["lessons"][0];
  EXPECT_EQ(l["lesson_id"], "web-first-seconds");
  ASSERT_EQ(l["points"].size(), 1u);
  EXPECT_EQ(l["points"][0]["uuid"], record.uuid());
  EXPECT_EQ(l["points"][0]["attempt"], 1);
  EXPECT_NEAR(l["points"][0]["score"].get<double>(), record.score(), 1e-9);
  EXPECT_EQ(l["pass_line"]["pain_s"], 30.0);
  EXPECT_EQ(l["pass_line"]["title"], "The first seconds");
  // The same session is a point of its case's curve too.
  ASSERT_EQ(curve["cases"].size(), 1u);
  EXPECT_EQ(curve["cases"][0]["points"].size(), 1u);
}

// Splits one CSV line of cells without quotes (what these sessions make).
std::vector<std::string> CsvCells(const std::string& line) {
  std::vector<std::string> cells;
  std::stringstream in(line);
  std::string cell;
  while (std::getline(in, cell, ',')) cells.push_back(cell);
  if (!line.empty() && line.back() == ',') cells.push_back("");
  return cells;
}

// The sessions export: one row per session in the date range, the columns
// documented, the same figures as the API's listing; the read rules and
// refusals of the listing; audited as session.export.
TEST_F(WebApiTest, SessionsExportAsCsvOneRowPerSession) {
  std::mt19937_64 rng(13);
  ves::v1::UploadSessionResponse up;
  std::vector<ves::v1::SessionRecord> records;
  for (int seed : {10, 11, 12}) {
    records.push_back(MakeRecord(NewUuid(rng), "t2", seed));
    ASSERT_TRUE(UploadSession(server_.Client(station_), records.back(), &up).ok());
  }
  const HttpResult r = Get("/api/v1/trainees/t2/sessions.csv", supervisor_);
  ASSERT_EQ(r.status, 200) << r.body;
  EXPECT_EQ(r.Header("content-type"), "text/csv; charset=utf-8");
  EXPECT_EQ(r.Header("content-disposition"), "attachment; filename=\"ves-sessions-t2.csv\"");
  EXPECT_EQ(r.Header("cache-control"), "no-store");
  std::vector<std::string> lines;
  for (size_t at = 0; at < r.body.size();) {
    const size_t end = r.body.find("\r\n", at);
    ASSERT_NE(end, std::string::npos) << "a line without CRLF: " << r.body.substr(at);
    lines.push_back(r.body.substr(at, end - at));
    at = end + 2;
  }
  ASSERT_EQ(lines.size(), 4u) << r.body;  // the header and one row per session
  EXPECT_EQ(CsvCells(lines[0]), SessionsCsvColumns());
  const auto column = [&](const std::string& name) {
    const auto& c = SessionsCsvColumns();
    return static_cast<size_t>(std::find(c.begin(), c.end(), name) - c.begin());
  };
  for (size_t i = 0; i < records.size(); ++i) {
    const std::vector<std::string> cells = CsvCells(lines[i + 1]);
    ASSERT_EQ(cells.size(), SessionsCsvColumns().size()) << lines[i + 1];
    const ves::v1::SessionRecord& rec = records[i];
    EXPECT_EQ(cells[column("session_uuid")], rec.uuid());
    EXPECT_EQ(cells[column("trainee_id")], "t2");
    EXPECT_EQ(cells[column("case_id")], "standard-adult");
    EXPECT_EQ(cells[column("case_version")], "1");
    EXPECT_EQ(cells[column("lesson_id")], "");
    EXPECT_EQ(cells[column("lesson_verdict")], "");
    EXPECT_EQ(cells[column("station_id")], "station-1");
    EXPECT_EQ(cells[column("outcome")], "cecum_reached");
    EXPECT_EQ(cells[column("completed")], "true");
    EXPECT_EQ(cells[column("duration_s")], "300.000");
    EXPECT_NEAR(std::stod(cells[column("time_to_cecum_s")]), rec.metrics().time_to_cecum_s(), 1e-3);
    EXPECT_NEAR(std::stod(cells[column("pain_s")]), rec.metrics().pain_s(), 1e-3);
    EXPECT_NEAR(std::stod(cells[column("score")]), rec.score(), 1e-2);
  }
  // MakeRecord's seed 10 starts at 1,700,000,600,000 ms.
  EXPECT_EQ(CsvCells(lines[1])[column("start_utc")], "2023-11-14T22:23:20.000Z");
  EXPECT_EQ(CsvCells(lines[1])[column("end_utc")], "2023-11-14T22:28:20.000Z");

  // A date range: from the second session's start (included) to the third's
  // (excluded).
  const std::string range = "?from_unix_ms=" + std::to_string(records[1].start_unix_ms()) +
                            "&to_unix_ms=" + std::to_string(records[2].start_unix_ms());
  const HttpResult one = Get("/api/v1/trainees/t2/sessions.csv" + range, supervisor_);
  ASSERT_EQ(one.status, 200) << one.body;
  EXPECT_EQ(std::count(one.body.begin(), one.body.end(), '\n'), 2) << one.body;
  EXPECT_NE(one.body.find(records[1].uuid()), std::string::npos) << one.body;
  const HttpResult none =
      Get("/api/v1/trainees/t2/sessions.csv?from_unix_ms=1800000000000", supervisor_);
  ASSERT_EQ(none.status, 200);
  EXPECT_EQ(std::count(none.body.begin(), none.body.end(), '\n'), 1) << none.body;

  // The listing's rules: another institution's trainee is a missing one, the
  // trainee itself may export its own, a station may not.
  EXPECT_EQ(Get("/api/v1/trainees/s1/sessions.csv", supervisor_).status, 404);
  EXPECT_EQ(Get("/api/v1/trainees/nobody/sessions.csv", supervisor_).status, 404);
  EXPECT_EQ(Get("/api/v1/trainees/t2/sessions.csv", trainee_t2_).status, 200);
  EXPECT_EQ(Get("/api/v1/trainees/t1/sessions.csv", trainee_t2_).status, 404);
  EXPECT_EQ(Get("/api/v1/trainees/t2/sessions.csv", station_).status, 403);
  EXPECT_EQ(Get("/api/v1/trainees/t2/sessions.csv").status, 401);
  const HttpResult backwards =
      Get("/api/v1/trainees/t2/sessions.csv?from_unix_ms=20&to_unix_ms=10", supervisor_);
  EXPECT_EQ(backwards.status, 400) << backwards.body;
  EXPECT_NE(backwards.body.find("to_unix_ms"), std::string::npos) << backwards.body;
  EXPECT_EQ(Get("/api/v1/trainees/t2/sessions.csv?from_unix_ms=x", supervisor_).status, 400);

  bool audited = false;
  for (int i = 0; i < 100 && !audited; ++i) {
    const json audit =
        json::parse(Get("/api/v1/audit?action=session.export&actor=supervisor@north", admin_).body);
    for (const auto& e : audit["entries"]) audited |= e["target"] == "t2" && e["result"] == "OK";
    if (!audited) std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  EXPECT_TRUE(audited);
}

// Cells a spreadsheet would misread: quoted per RFC 4180, formulas defused,
// a lesson's verdict and its checks on one line.
TEST(SessionsCsv, QuotesCellsAndDefusesFormulas) {
  patient_db::SessionRow s;
  s.uuid = "u1";
  s.trainee_id = "=HYPERLINK(\"x\",1)";
  s.case_id = "-case";
  s.station_id = "ward 3, bed \"A\"";
  s.lesson_id = "l1";
  s.start_unix_ms = 1'000;
  s.end_unix_ms = 61'500;
  s.outcome = ves::v1::OUTCOME_TIMED_OUT;
  s.completed = false;
  s.time_to_cecum_s = 12;
  patient_db::LessonVerdictRow v;
  v.session_uuid = "u1";
  v.passed = false;
  v.detail = "pain_s 31 <= 30: FAILED\ndamage_events 0 <= 0: ok\n";
  patient_db::SessionRow pending = s;
  pending.uuid = "u2";
  patient_db::SessionRow free_run = s;
  free_run.uuid = "u3";
  free_run.lesson_id.clear();
  const std::string csv = SessionsCsv({s, pending, free_run}, {v});
  const size_t first = csv.find("\r\n") + 2;
  const std::string row = csv.substr(first, csv.find("\r\n", first) - first);
  EXPECT_EQ(row,
            "u1,\"'=HYPERLINK(\"\"x\"\",1)\",'-case,0,l1,failed,"
            "pain_s 31 <= 30: FAILED; damage_events 0 <= 0: ok,\"ward 3, bed \"\"A\"\"\",,"
            "1970-01-01T00:00:01.000Z,1970-01-01T00:01:01.500Z,60.500,timed_out,false,,0.000,"
            "0.0000,0.00,,");  // loop and X-ray time not known: empty
  EXPECT_NE(csv.find("\r\nu2,\"'=HYPERLINK(\"\"x\"\",1)\",'-case,0,l1,pending,,"),
            std::string::npos)
      << csv;
  EXPECT_NE(csv.find("\r\nu3,\"'=HYPERLINK(\"\"x\"\",1)\",'-case,0,,,,"), std::string::npos) << csv;
  EXPECT_EQ(std::count(csv.begin(), csv.end(), '\n'), 4);
}

}  // namespace
}  // namespace ves::server::testing

namespace ves::server::testing {
namespace {

// Shutdown does not wait for an idle browser connection: it is closed.
TEST(WebServerShutdown, IdleConnectionsAreClosedOnShutdown) {
  ServerOptions o;
  o.http_listen = "127.0.0.1:0";
  auto server = std::make_unique<TestServer>(o);
  boost::asio::io_context io;
  boost::asio::ip::tcp::socket idle(io);
  idle.connect({boost::asio::ip::make_address("127.0.0.1"),
                static_cast<unsigned short>(server->server().http_port())});
  EXPECT_EQ(HttpCall(server->server().http_port(), "GET", "/healthz").status, 200);
  server.reset();  // returns although `idle` never sent a request
  char byte = 0;
  boost::system::error_code ec;
  idle.read_some(boost::asio::buffer(&byte, 1), ec);
  EXPECT_TRUE(ec == boost::asio::error::eof || ec == boost::asio::error::connection_reset)
      << ec.message();
}

}  // namespace
}  // namespace ves::server::testing
