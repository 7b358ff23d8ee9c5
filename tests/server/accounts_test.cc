// People's accounts (docs/web.md, "Accounts") against a real server on
// loopback: password sign-in to a cookie session, throttled wrong passwords,
// expiry, revocation within one request, `ves-admin account`, and no password
// or secret in the server's log or the audit rows.
#include "server/accounts.h"

#include <gtest/gtest.h>
#include <sys/wait.h>

#include <atomic>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "patient_db/store_factory.h"
#include "tests/integration/test_server.h"
#include "tests/server/log_capture.h"
#include "tests/server/web_fixture.h"
#include "tests/server/web_client.h"

namespace ves::server::testing {
namespace {

using nlohmann::json;
using patient_db::AccountRow;
using patient_db::StoreRole;

const char kAlicePassword[] = "correct horse battery staple";

int64_t WallMs() {
  return std::chrono::duration_cast<std::chrono::milliseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

TEST(PasswordHash, RoundTripsSaltedAndRefusesAnythingElse) {
  const std::string h = HashPassword(kAlicePassword);
  EXPECT_EQ(h.rfind("$scrypt$ln=15,r=8,p=1$", 0), 0u) << h;
  EXPECT_EQ(h.find(kAlicePassword), std::string::npos);
  EXPECT_TRUE(VerifyPassword(kAlicePassword, h));
  EXPECT_FALSE(VerifyPassword("correct horse battery stapl", h));
  EXPECT_FALSE(VerifyPassword("", h));
  EXPECT_NE(HashPassword(kAlicePassword), h) << "the salt must differ per hash";
  EXPECT_FALSE(VerifyPassword(kAlicePassword, ""));
  EXPECT_FALSE(VerifyPassword(kAlicePassword, "$scrypt$ln=40,r=8,p=1$AAAA$AAAA"));
  std::string tampered = h;
  tampered[tampered.size() - 3] = tampered[tampered.size() - 3] == 'A' ? 'B' : 'A';
  EXPECT_FALSE(VerifyPassword(kAlicePassword, tampered));
}

TEST(PasswordHash, NewPasswordsAndUsernamesAreChecked) {
  EXPECT_EQ(CheckNewPassword("short"), "password: 5 bytes; must be 12..128");
  EXPECT_NE(CheckNewPassword(std::string(129, 'x')), "");
  EXPECT_NE(CheckNewPassword("twelve chars\n!"), "");
  EXPECT_EQ(CheckNewPassword(kAlicePassword), "");
  EXPECT_EQ(CheckUsername("dr.alice@north-1"), "");
  EXPECT_NE(CheckUsername("Alice"), "");
  EXPECT_NE(CheckUsername(""), "");
  EXPECT_NE(CheckUsername(std::string(65, 'a')), "");
}

class AccountsTest : public WebServerTest {
 protected:
  AccountsTest() : WebServerTest(/*log_calls=*/true) {}

  void SetUp() override {
    admin_token_ = server_.MakeToken(StoreRole::kAdmin, "north");
    server_.MakeToken(StoreRole::kSupervisor, "south");  // creates the institution
    server_.AddTrainee("t1", "north");
    AddAccount("alice", StoreRole::kSupervisor, "north", kAlicePassword);
    AddAccount("bob", StoreRole::kAdmin, "north", "bob's long password");
    server_.server().auth().accounts().SetClockForTest([this] { return now_ms_.load(); });
  }

  void AddAccount(const std::string& name, StoreRole role, const std::string& institution,
                  const std::string& password, int64_t expires = 0) {
    AccountRow a{name, role, institution, HashPassword(password), "", 1, expires, 0};
    ASSERT_TRUE(server_.store().AddAccount(a).ok());
  }

  HttpResult SignIn(const std::string& username, const std::string& password) {
    return HttpCall(port(), "POST", "/api/v1/sign-in", {{"Content-Type", "application/json"}},
                    json{{"username", username}, {"password", password}}.dump());
  }
  HttpResult Me(const std::string& cookie) {
    return HttpCall(port(), "GET", "/api/v1/me", {{"Cookie", cookie}});
  }
  std::vector<patient_db::AuditRow> Audit() {
    // The writer commits audit rows in groups: wait until the count settles.
    std::vector<patient_db::AuditRow> rows;
    for (int i = 0; i < 50; ++i) {
      auto r = server_.store().ListAudit(0, 10000);
      EXPECT_TRUE(r.ok());
      if (i > 0 && r.value.size() == rows.size()) break;
      rows = r.value;
      std::this_thread::sleep_for(std::chrono::milliseconds(40));
    }
    return rows;
  }

  std::string admin_token_;
  std::atomic<int64_t> now_ms_{WallMs()};
};

TEST_F(AccountsTest, PasswordSignInOpensACookieSessionThatActsAsTheAccount) {
  const HttpResult r = SignIn("alice", kAlicePassword);
  ASSERT_EQ(r.status, 200) << r.body;
  const json body = json::parse(r.body);
  EXPECT_EQ(body["role"], "supervisor");
  EXPECT_EQ(body["institution"], "north");
  EXPECT_EQ(body["label"], "alice");
  const std::string set_cookie = r.Header("set-cookie");
  EXPECT_NE(set_cookie.find("HttpOnly"), std::string::npos) << set_cookie;
  EXPECT_NE(set_cookie.find("SameSite=Strict"), std::string::npos) << set_cookie;
  const std::string cookie = CookieOf(r);
  const HttpResult me = Me(cookie);
  ASSERT_EQ(me.status, 200) << me.body;
  EXPECT_EQ(json::parse(me.body)["label"], "alice");
  // The account's role and institution rule what it reaches.
  EXPECT_EQ(HttpCall(port(), "GET", "/api/v1/trainees/t1/sessions", {{"Cookie", cookie}}).status,
            200);
  EXPECT_EQ(HttpCall(port(), "GET", "/api/v1/audit", {{"Cookie", cookie}}).status, 403);
  // A state change needs the CSRF token, as for a token sign-in.
  const HttpResult no_csrf = HttpCall(port(), "POST", "/api/v1/sign-out",
                                      {{"Cookie", cookie}, {"Content-Type", "application/json"}},
                                      "{}");
  EXPECT_EQ(no_csrf.status, 403);
  const HttpResult out = HttpCall(port(), "POST", "/api/v1/sign-out",
                                  {{"Cookie", cookie},
                                   {"Content-Type", "application/json"},
                                   {"X-CSRF-Token", body["csrf_token"].get<std::string>()}},
                                  "{}");
  EXPECT_EQ(out.status, 200) << out.body;
  EXPECT_EQ(Me(cookie).status, 401);

  bool audited = false;
  for (const auto& row : Audit()) {
    if (row.action == "web.sign_in" && row.actor == "account:alice" && row.result == "OK") {
      audited = true;
      EXPECT_EQ(row.target, "from 127.0.0.1");
    }
  }
  EXPECT_TRUE(audited);
}

TEST_F(AccountsTest, WrongPasswordsAreThrottledPerAccount) {
  for (int i = 0; i < kMaxWrongPerAccount; ++i) {
    const HttpResult r = SignIn("alice", "wrong password " + std::to_string(i));
    EXPECT_EQ(r.status, 401) << i << ": " << r.body;
    EXPECT_EQ(json::parse(r.body)["error"]["message"], "wrong username or password");
  }
  // Closed now, even to the right password; another account is not.
  const HttpResult closed = SignIn("alice", kAlicePassword);
  EXPECT_EQ(closed.status, 429) << closed.body;
  const int retry = std::stoi(closed.Header("retry-after"));
  EXPECT_GT(retry, 14 * 60);
  EXPECT_LE(retry, 15 * 60);
  EXPECT_EQ(SignIn("bob", "bob's long password").status, 200);
  // 15 minutes later the window has passed.
  now_ms_ += kWrongWindowMs + 1000;
  EXPECT_EQ(SignIn("alice", kAlicePassword).status, 200);
  // A success clears the count: four more wrong ones do not close it.
  for (int i = 0; i < kMaxWrongPerAccount - 1; ++i) EXPECT_EQ(SignIn("alice", "nope").status, 401);
  EXPECT_EQ(SignIn("alice", kAlicePassword).status, 200);

  int refused_rows = 0;
  for (const auto& row : Audit()) {
    if (row.action == "web.sign_in" && row.actor == "account:alice" &&
        row.result.rfind("RESOURCE_EXHAUSTED", 0) == 0) {
      ++refused_rows;
    }
  }
  EXPECT_EQ(refused_rows, 1);
}

TEST_F(AccountsTest, WrongPasswordsAreThrottledPerSourceAddress) {
  // Unknown names count against the source as wrong passwords do.
  for (int i = 0; i < kMaxWrongPerSource; ++i) {
    const std::string name = "nobody" + std::to_string(i);
    EXPECT_EQ(SignIn(name, "guess").status, 401) << name;
  }
  const HttpResult r = SignIn("bob", "bob's long password");
  EXPECT_EQ(r.status, 429) << r.body;
  EXPECT_NE(json::parse(r.body)["error"]["message"].get<std::string>().find("from this address"),
            std::string::npos);
  now_ms_ += kWrongWindowMs;
  EXPECT_EQ(SignIn("bob", "bob's long password").status, 200);
}

TEST_F(AccountsTest, ExpiredAccountIsRefusedAtSignInAndOnTheNextRequest) {
  AddAccount("carol", StoreRole::kSupervisor, "north", "carol's long password",
             now_ms_.load() + 60'000);
  const HttpResult r = SignIn("carol", "carol's long password");
  ASSERT_EQ(r.status, 200) << r.body;
  const std::string cookie = CookieOf(r);
  EXPECT_EQ(Me(cookie).status, 200);
  now_ms_ += 61'000;  // past the account's expiry, within the session's 8 h
  const HttpResult after = Me(cookie);
  EXPECT_EQ(after.status, 401);
  EXPECT_EQ(json::parse(after.body)["error"]["message"], "account 'carol' has expired");
  const HttpResult again = SignIn("carol", "carol's long password");
  EXPECT_EQ(again.status, 401);
  EXPECT_EQ(json::parse(again.body)["error"]["message"], "account 'carol' has expired");
}

TEST_F(AccountsTest, RevokedAccountIsRefusedWithinOneRequest) {
  const HttpResult r = SignIn("alice", kAlicePassword);
  ASSERT_EQ(r.status, 200) << r.body;
  const std::string cookie = CookieOf(r);
  ASSERT_EQ(Me(cookie).status, 200);
  ASSERT_TRUE(server_.store().RevokeAccount("alice", WallMs()).ok());
  const HttpResult next = Me(cookie);  // the very next request
  EXPECT_EQ(next.status, 401) << next.body;
  EXPECT_EQ(json::parse(next.body)["error"]["message"], "account 'alice' was revoked");
  EXPECT_EQ(SignIn("alice", kAlicePassword).status, 401);
  // Tokens are untouched: stations and scripts go on.
  EXPECT_EQ(HttpCall(port(), "GET", "/api/v1/me", {{"Authorization", "Bearer " + admin_token_}})
                .status,
            200);
}

TEST_F(AccountsTest, BadSignInBodiesAreRefusedNamingTheField) {
  const auto body_of = [&](const std::string& body) {
    return HttpCall(port(), "POST", "/api/v1/sign-in", {{"Content-Type", "application/json"}},
                    body);
  };
  HttpResult r = SignIn("Alice Smith", kAlicePassword);
  EXPECT_EQ(r.status, 400);
  EXPECT_EQ(json::parse(r.body)["error"]["message"], "username: only a-z, 0-9, '.', '_', '@' and '-'");
  r = SignIn("alice", std::string(129, 'x'));
  EXPECT_EQ(r.status, 400);
  EXPECT_EQ(json::parse(r.body)["error"]["message"], "password: must be 1..128 bytes");
  r = body_of(R"({"username": "alice"})");
  EXPECT_EQ(r.status, 400);
  r = body_of(R"({"username": 7, "password": "x"})");
  EXPECT_EQ(r.status, 400);
  EXPECT_EQ(SignIn("alice", "").status, 400);
}

TEST_F(AccountsTest, NoPasswordTokenOrSecretInTheLogOrTheAudit) {
  LogCapture log;
  const std::string wrong = "not-alices-password-xyzzy";
  EXPECT_EQ(SignIn("alice", wrong).status, 401);
  const HttpResult ok = SignIn("alice", kAlicePassword);
  ASSERT_EQ(ok.status, 200);
  const std::string cookie = CookieOf(ok);
  const std::string session_id = cookie.substr(cookie.find('=') + 1);
  const std::string csrf = json::parse(ok.body)["csrf_token"];
  EXPECT_EQ(Me(cookie).status, 200);
  const HttpResult by_token =
      HttpCall(port(), "POST", "/api/v1/sign-in", {{"Content-Type", "application/json"}},
               json{{"token", admin_token_}}.dump());
  ASSERT_EQ(by_token.status, 200);
  EXPECT_EQ(SignIn("nobody", wrong).status, 401);

  const std::string text = log.Text();
  EXPECT_NE(text.find("/api/v1/sign-in"), std::string::npos) << "the log was not captured";
  std::string rows;
  for (const auto& row : Audit()) {
    rows += row.actor + "|" + row.actor_label + "|" + row.institution + "|" + row.action + "|" +
            row.target + "|" + row.result + "\n";
  }
  EXPECT_NE(rows.find("account:alice"), std::string::npos) << rows;
  for (const std::string& secret :
       {std::string(kAlicePassword), wrong, session_id, csrf, admin_token_}) {
    EXPECT_EQ(text.find(secret), std::string::npos) << "in the log: " << secret;
    EXPECT_EQ(rows.find(secret), std::string::npos) << "in the audit: " << secret;
  }
}

struct AdminRun {
  int exit_status = -1;
  std::string out;
};

AdminRun Admin(const std::string& args, const std::string& stdin_text) {
  const auto dir = MakeTempDir("account_cli");
  std::ofstream(dir / "in.txt") << stdin_text;
  const std::string command = std::string(VES_ADMIN_PATH) + " " + args + " <'" +
                              (dir / "in.txt").string() + "' 2>&1";
  AdminRun run;
  FILE* pipe = ::popen(command.c_str(), "r");
  char buf[4096];
  size_t n;
  while ((n = std::fread(buf, 1, sizeof buf, pipe)) > 0) run.out.append(buf, n);
  const int status = ::pclose(pipe);
  run.exit_status = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  std::filesystem::remove_all(dir);
  return run;
}

TEST(AccountCommand, CreatesListsRevokesAndAudits) {
  const auto dir = MakeTempDir("account_cmd");
  const std::string db = "sqlite:" + (dir / "ves.db").string();
  ASSERT_TRUE(patient_db::OpenStoreFromUrl(db)->AddInstitution("north", 1).ok());
  const std::string create = "account create --db " + db +
                             " --username dr.x --role supervisor --institution north"
                             " --expires 2099-01-31";
  AdminRun r = Admin(create, "short\n");
  EXPECT_EQ(r.exit_status, 2) << r.out;
  EXPECT_NE(r.out.find("password: 5 bytes"), std::string::npos) << r.out;
  r = Admin(create, "a long enough password\n");
  ASSERT_EQ(r.exit_status, 0) << r.out;
  EXPECT_EQ(Admin(create, "a long enough password\n").exit_status, 1);
  EXPECT_EQ(Admin("account create --db " + db +
                      " --username dr.y --role trainee --institution north",
                  "a long enough password\n")
                .exit_status,
            2);
  EXPECT_EQ(Admin("account create --db " + db +
                      " --username dr.y --role admin --institution north --expires 2099-02-30",
                  "a long enough password\n")
                .exit_status,
            2);
  r = Admin("account list --db " + db, "");
  ASSERT_EQ(r.exit_status, 0) << r.out;
  EXPECT_NE(r.out.find("dr.x\tsupervisor\tnorth\tyes\t-\t2099-01-31T00:00Z\t-"),
            std::string::npos)
      << r.out;
  {
    auto store = patient_db::OpenStoreFromUrl(db);
    auto a = store->GetAccount("dr.x");
    ASSERT_TRUE(a.ok());
    EXPECT_TRUE(VerifyPassword("a long enough password", a.value.password_hash));
    EXPECT_EQ(a.value.revoked_unix_ms, 0);
  }
  r = Admin("account password --db " + db + " --username dr.x", "another long password\n");
  ASSERT_EQ(r.exit_status, 0) << r.out;
  r = Admin("account revoke --db " + db + " --username dr.x", "");
  ASSERT_EQ(r.exit_status, 0) << r.out;
  EXPECT_EQ(Admin("account revoke --db " + db + " --username nobody", "").exit_status, 1);
  auto store = patient_db::OpenStoreFromUrl(db);
  auto a = store->GetAccount("dr.x");
  ASSERT_TRUE(a.ok());
  EXPECT_TRUE(VerifyPassword("another long password", a.value.password_hash));
  EXPECT_GT(a.value.revoked_unix_ms, 0);
  std::vector<std::string> actions;
  for (const auto& row : store->ListAudit(0, 100).value) {
    actions.push_back(row.action + " " + row.target);
    EXPECT_EQ(row.result.find("password"), std::string::npos);
  }
  EXPECT_EQ(actions, (std::vector<std::string>{"account.create dr.x", "account.password dr.x",
                                               "account.revoke dr.x"}));
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace ves::server::testing
