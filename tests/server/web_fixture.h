#pragma once

#include <gtest/gtest.h>

#include <chrono>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>
#include <utility>

#include "patient_db/store.h"
#include "tests/integration/test_server.h"
#include "tests/server/web_client.h"

// The fixture the HTTP API tests share: a TestServer with its HTTP listener
// on loopback, and calls to it as a script (Bearer) or a browser (cookie and
// CSRF token) makes them.
namespace ves::server::testing {

class WebServerTest : public ::testing::Test {
 protected:
  explicit WebServerTest(bool log_calls = false) : server_(WithHttp(), log_calls) {}

  static ServerOptions WithHttp() {
    ServerOptions o;
    o.http_listen = "127.0.0.1:0";
    return o;
  }

  int port() { return server_.server().http_port(); }

  // GET with a Bearer token ("" : none).
  HttpResult Get(const std::string& target, const std::string& token = "") {
    Headers h;
    if (!token.empty()) h.emplace_back("Authorization", "Bearer " + token);
    return HttpCall(port(), "GET", target, h);
  }
  // POST of a JSON body with a Bearer token.
  HttpResult Post(const std::string& target, const std::string& token,
                  const nlohmann::json& body) {
    return HttpCall(port(), "POST", target,
                    {{"Authorization", "Bearer " + token}, {"Content-Type", "application/json"}},
                    body.dump());
  }

  // A browser session for `token`: the cookie pair and the CSRF token.
  std::pair<std::string, std::string> SignIn(const std::string& token,
                                             HttpResult* reply = nullptr) {
    HttpResult r =
        HttpCall(port(), "POST", "/api/v1/sign-in", {{"Content-Type", "application/json"}},
                 nlohmann::json{{"token", token}}.dump());
    EXPECT_EQ(r.status, 200) << r.body;
    if (reply) *reply = r;
    return {CookieOf(r), nlohmann::json::parse(r.body)["csrf_token"]};
  }
  // The cookie pair of a reply's Set-Cookie.
  static std::string CookieOf(const HttpResult& r) {
    const std::string set_cookie = r.Header("set-cookie");
    return set_cookie.substr(0, set_cookie.find(';'));
  }
  // The error message of a refusal ("" when the body has none).
  static std::string ErrorMessageOf(const HttpResult& r) {
    const nlohmann::json j = nlohmann::json::parse(r.body, nullptr, false);
    return j.is_object() && j.contains("error") ? j["error"]["message"].get<std::string>() : "";
  }

  // Whether an audit row of `action` on `target` whose result starts with
  // `result` is in the store, waiting for the group commit to write it.
  bool Audited(const std::string& action, const std::string& target, const std::string& result) {
    for (int i = 0; i < 100; ++i) {
      patient_db::AuditQuery q;
      q.action = action;
      q.limit = 10000;
      auto rows = server_.store().ListAuditNewest(q);
      EXPECT_TRUE(rows.ok());
      for (const auto& r : rows.value) {
        if (r.target == target && r.result.rfind(result, 0) == 0) return true;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
    return false;
  }

  TestServer server_;
};

}  // namespace ves::server::testing
