// Every route of the HTTP route table (server/web_routes.h) against the
// request pipeline (server/pipeline.h), walked from the table itself so that a
// new route is covered when it is added:
//   - an oversized body: 413 naming the body, from the HTTP bounds stage;
//   - a bad token and a forged cookie: 401 (AdmitRequest; not audited, as
//     pipeline.h says: there is nobody to name yet);
//   - an over-long path parameter with a good token: 400 naming the field
//     (AdmitRequest's bounds, before authentication looks at the store);
//   - a role the row does not list: 403 and an audit row of that refusal
//     (RunCall audits every role refusal).
// Public rows (no roles: health, pages, signing in) answer a bad token as
// they answer none.
#include <gtest/gtest.h>

#include <algorithm>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <string>

#include "server/web_api.h"
#include "server/web_routes.h"
#include "tests/server/web_fixture.h"

namespace ves::server::testing {
namespace {

using nlohmann::json;
using patient_db::StoreRole;

constexpr char kUuid[] = "00000000-0000-4000-8000-000000000001";

// Sample values of the patterns' parameters.
const std::map<std::string, std::string>& SampleParams() {
  static const std::map<std::string, std::string> params = {
      {"id", "t1"}, {"uuid", kUuid}, {"group", "g1"}, {"page", "index.html"}};
  return params;
}

// A body each POST row accepts as well-formed (its role and store rules
// decide the rest); "{}" for a row not listed here.
std::string SampleBody(const WebRoute& route) {
  static const std::map<std::string, std::string> bodies = {
      {"/api/v1/trainees", R"({"trainee_id": "n1", "display_name": "N"})"},
      {"/api/v1/assignments", R"({"curriculum_id": "c1", "trainee_id": "t1"})"},
      {"/api/v1/trainees/{id}/group", R"({"group": "g2"})"},
      {"/api/v1/sessions/{uuid}/notes", R"({"text": "a note"})"},
      {"/api/v1/sign-in", R"({"token": "0123456789abcdef"})"}};
  auto it = bodies.find(route.pattern);
  return it == bodies.end() ? "{}" : it->second;
}

// A pattern's parts between its slashes.
std::vector<std::string> SplitPattern(const std::string& pattern) {
  std::vector<std::string> parts;
  size_t start = 0;
  while (true) {
    const size_t end = pattern.find('/', start);
    parts.push_back(pattern.substr(start, end == std::string::npos ? end : end - start));
    if (end == std::string::npos) return parts;
    start = end + 1;
  }
}

// The route's pattern with its parameters filled in (`long_param`: each one
// over any id's bound instead).
std::string TargetOf(const WebRoute& route, bool long_param = false) {
  std::string target;
  for (const std::string& part : SplitPattern(route.pattern)) {
    if (part.empty()) continue;
    target += "/";
    if (part.size() > 2 && part.front() == '{' && part.back() == '}') {
      const std::string name = part.substr(1, part.size() - 2);
      target += long_param ? std::string(300, 'x') : SampleParams().at(name);
    } else {
      target += part;
    }
  }
  if (target.empty()) target = "/";
  // The live viewer's session; ignored by the other routes.
  return target + "?session=" + kUuid;
}

class WebRoutesPipelineTest : public WebServerTest {
 protected:
  void SetUp() override {
    server_.AddTrainee("t1", "north");
    tokens_[StoreRole::kAdmin] = server_.MakeToken(StoreRole::kAdmin, "north");
    tokens_[StoreRole::kSupervisor] = server_.MakeToken(StoreRole::kSupervisor, "north");
    tokens_[StoreRole::kStation] = server_.MakeToken(StoreRole::kStation, "north");
    tokens_[StoreRole::kTrainee] = server_.MakeToken(StoreRole::kTrainee, "north", "t1");
  }

  // The route's request with these extra headers and body.
  HttpResult Call(const WebRoute& route, const std::string& target, Headers headers,
                  const std::string& body) {
    const std::string method = route.method;
    if (method == "WS") {
      headers.insert(headers.end(), {{"Connection", "Upgrade"},
                                     {"Upgrade", "websocket"},
                                     {"Sec-WebSocket-Version", "13"},
                                     {"Sec-WebSocket-Key", "dGhlIHNhbXBsZSBub25jZQ=="}});
      return HttpCall(port(), "GET", target, headers);
    }
    if (method == "POST") headers.emplace_back("Content-Type", "application/json");
    return HttpCall(port(), method, target, headers, body);
  }
  HttpResult CallWithToken(const WebRoute& route, const std::string& token,
                           bool long_param = false) {
    Headers h;
    if (!token.empty()) h.emplace_back("Authorization", "Bearer " + token);
    return Call(route, TargetOf(route, long_param), h, SampleBody(route));
  }

  // The number of audit rows of `role` refused by the role stage.
  size_t RoleRefusals(StoreRole role) {
    auto rows = server_.store().ListAuditNewest(patient_db::AuditQuery{});
    EXPECT_TRUE(rows.ok());
    return std::count_if(rows.value.begin(), rows.value.end(), [&](const patient_db::AuditRow& r) {
      return r.role == patient_db::RoleName(role) && r.result.rfind("PERMISSION_DENIED", 0) == 0;
    });
  }

  std::map<StoreRole, std::string> tokens_;
};

std::string Describe(const WebRoute& route) {
  return std::string(route.method) + " " + route.pattern;
}

TEST_F(WebRoutesPipelineTest, TheTableHasEachMethodAndPatternOnceAndEveryApiRouteHasRoles) {
  std::set<std::string> seen;
  for (const WebRoute& route : WebRoutes()) {
    EXPECT_TRUE(seen.insert(Describe(route)).second) << Describe(route) << " twice";
    const std::string method = route.method;
    EXPECT_TRUE(method == "GET" || method == "POST" || method == "WS") << Describe(route);
    ASSERT_NE(route.handler, nullptr) << Describe(route);
  }
  // The public rows are exactly these: health, pages and signing in.
  std::set<std::string> open;
  for (const WebRoute& route : WebRoutes()) {
    if (route.roles.empty()) open.insert(Describe(route));
  }
  EXPECT_EQ(open, (std::set<std::string>{"GET /healthz", "GET /", "GET /{page}",
                                         "GET /api/v1/sign-in", "POST /api/v1/sign-in",
                                         "GET /api/v1/oidc/start", "GET /api/v1/oidc/callback"}));
}

TEST_F(WebRoutesPipelineTest, AnOversizedBodyIsRefusedOnEveryRoute) {
  for (const WebRoute& route : WebRoutes()) {
    const bool ws = std::string(route.method) == "WS";
    // Raw bytes: the server stops reading at the header and may close early.
    const std::string request =
        std::string(ws ? "GET" : route.method) + " " + TargetOf(route) + " HTTP/1.1\r\n" +
        "Host: x\r\nAuthorization: Bearer " + tokens_[StoreRole::kAdmin] + "\r\n" +
        "Content-Type: application/json\r\n" +
        (ws ? "Connection: Upgrade\r\nUpgrade: websocket\r\nSec-WebSocket-Version: 13\r\n"
              "Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\n"
            : "") +
        "Content-Length: " + std::to_string(kMaxHttpBodyBytes + 1) + "\r\n\r\n" +
        std::string(kMaxHttpBodyBytes + 1, ' ');
    const HttpResult r = HttpRaw(port(), request);
    EXPECT_EQ(r.status, 413) << Describe(route) << ": " << r.body;
    EXPECT_NE(ErrorMessageOf(r).find("body"), std::string::npos) << Describe(route) << r.body;
  }
}

TEST_F(WebRoutesPipelineTest, ABadTokenOrAForgedCookieIs401AndNotAudited) {
  for (const WebRoute& route : WebRoutes()) {
    const HttpResult bad = CallWithToken(route, "0123456789abcdef");
    if (route.roles.empty()) {
      EXPECT_EQ(bad.status, CallWithToken(route, "").status)
          << Describe(route) << ": a public route does not read the token";
      continue;
    }
    EXPECT_EQ(bad.status, 401) << Describe(route) << ": " << bad.body;
    EXPECT_EQ(json::parse(bad.body)["error"]["code"], "UNAUTHENTICATED") << Describe(route);
    const HttpResult forged =
        Call(route, TargetOf(route), {{"Cookie", "ves_session=forged"}}, SampleBody(route));
    EXPECT_EQ(forged.status, 401) << Describe(route) << " with a forged cookie: " << forged.body;
  }
  // The audit rows are written in order (one group commit): once a later
  // refusal's row is there, any row of the calls above would be too.
  const WebRoute* audit = nullptr;
  for (const WebRoute& route : WebRoutes()) {
    if (std::string(route.pattern) == "/api/v1/audit") audit = &route;
  }
  ASSERT_NE(audit, nullptr);
  EXPECT_EQ(CallWithToken(*audit, tokens_[StoreRole::kSupervisor]).status, 403);
  ASSERT_TRUE(Audited("audit.list", "", "PERMISSION_DENIED"));
  auto rows = server_.store().ListAuditNewest(patient_db::AuditQuery{});
  ASSERT_TRUE(rows.ok());
  for (const auto& r : rows.value) {
    EXPECT_NE(r.result.rfind("UNAUTHENTICATED", 0), 0u) << r.action << " " << r.target;
  }
}

TEST_F(WebRoutesPipelineTest, AnOverLongPathParameterIs400NamingTheField) {
  for (const WebRoute& route : WebRoutes()) {
    if (route.roles.empty() || std::string(route.pattern).find('{') == std::string::npos) continue;
    const HttpResult r = CallWithToken(route, tokens_[StoreRole::kAdmin], /*long_param=*/true);
    EXPECT_EQ(r.status, 400) << Describe(route) << ": " << r.body;
    const std::string message = ErrorMessageOf(r);
    bool names_it = false;
    for (const auto& [name, value] : SampleParams()) {
      names_it |= std::string(route.pattern).find("{" + name + "}") != std::string::npos &&
                  message.find(name) != std::string::npos;
    }
    EXPECT_TRUE(names_it) << Describe(route) << ": " << message;
  }
}

TEST_F(WebRoutesPipelineTest, ARoleTheRowDoesNotListIs403AndAudited) {
  const std::vector<StoreRole> all = {StoreRole::kAdmin, StoreRole::kSupervisor,
                                      StoreRole::kStation, StoreRole::kTrainee};
  int checked = 0;
  for (const WebRoute& route : WebRoutes()) {
    if (route.roles.empty()) continue;
    for (StoreRole role : all) {
      if (std::find(route.roles.begin(), route.roles.end(), role) != route.roles.end()) continue;
      const size_t before = RoleRefusals(role);
      const HttpResult r = CallWithToken(route, tokens_[role]);
      EXPECT_EQ(r.status, 403) << Describe(route) << " as " << patient_db::RoleName(role) << ": "
                               << r.body;
      EXPECT_EQ(ErrorMessageOf(r).rfind("role '", 0), 0u) << Describe(route) << ": " << r.body;
      bool audited = false;
      for (int i = 0; i < 100 && !audited; ++i) {
        audited = RoleRefusals(role) > before;
        if (!audited) std::this_thread::sleep_for(std::chrono::milliseconds(20));
      }
      EXPECT_TRUE(audited) << Describe(route) << " as " << patient_db::RoleName(role)
                           << ": no audit row of the refusal";
      ++checked;
    }
    // Each role the row lists gets past the role stage.
    for (StoreRole role : route.roles) {
      const HttpResult allowed = CallWithToken(route, tokens_[role]);
      EXPECT_NE(allowed.status, 500) << Describe(route) << ": " << allowed.body;
      EXPECT_NE(ErrorMessageOf(allowed).rfind("role '", 0), 0u)
          << Describe(route) << " as " << patient_db::RoleName(role) << ": " << allowed.body;
    }
  }
  EXPECT_GT(checked, 20);
}

}  // namespace
}  // namespace ves::server::testing
