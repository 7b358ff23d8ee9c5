// Sign-in through an OpenID Connect provider (docs/web.md): a real ves-server
// on loopback against tests/server/oidc_test_idp.py, with this test as the
// browser following the redirects. A good sign-in maps the provider's
// subject (or verified email) to an account; a forged or spoiled ID token, a
// wrong state, a replayed callback, an unknown subject and a revoked account
// are refused; no code, token or secret reaches the log or the audit.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <boost/asio/ip/tcp.hpp>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <thread>

#include "server/accounts.h"
#include "server/oidc.h"
#include "tests/integration/test_server.h"
#include "tests/server/log_capture.h"
#include "tests/server/web_client.h"

namespace ves::server::testing {
namespace {

using nlohmann::json;
using patient_db::AccountRow;
using patient_db::StoreRole;

constexpr char kClientId[] = "ves-test-client";
constexpr char kClientSecret[] = "client-secret-9f8e7d6c5b4a";

TEST(Base64Url, RoundTripsAndRefusesOtherAlphabets) {
  for (const std::string& s : {std::string(""), std::string("f"), std::string("fo"),
                               std::string("foo"), std::string("\xff\xfe\x00\x01", 4)}) {
    std::string back;
    ASSERT_TRUE(Base64UrlDecode(Base64UrlEncode(s), &back));
    EXPECT_EQ(back, s);
  }
  EXPECT_EQ(Base64UrlEncode("\xfb\xff"), "-_8");
  std::string out;
  EXPECT_FALSE(Base64UrlDecode("ab+/", &out));
  EXPECT_FALSE(Base64UrlDecode("a", &out));
}

TEST(OidcConfigCheck, RefusesPlainHttpOffLoopbackAndMissingFields) {
  OidcConfig c{"https://sso.hospital.org/realms/ves", "ves", "secret",
               "https://ves.hospital.org/api/v1/oidc/callback", "", "openid"};
  EXPECT_EQ(CheckOidcConfig(c), "");
  OidcConfig http = c;
  http.issuer = "http://sso.hospital.org/realms/ves";
  EXPECT_NE(CheckOidcConfig(http).find("--oidc-issuer"), std::string::npos);
  http.issuer = "http://127.0.0.1:8080/realms/ves";
  EXPECT_EQ(CheckOidcConfig(http), "");
  OidcConfig no_secret = c;
  no_secret.client_secret = "";
  EXPECT_NE(CheckOidcConfig(no_secret).find("--oidc-client-secret-file"), std::string::npos);
  OidcConfig no_id = c;
  no_id.client_id = "";
  EXPECT_NE(CheckOidcConfig(no_id).find("--oidc-client-id"), std::string::npos);
}

TEST(IdTokenCheck, RefusesMalformedTokensBeforeAnyKeyIsUsed) {
  IdTokenClaims claims;
  const json no_keys = {{"keys", json::array()}};
  EXPECT_EQ(VerifyIdToken("", no_keys, "i", "c", "n", 0, &claims),
            "id_token: empty or over 16384 bytes");
  EXPECT_EQ(VerifyIdToken("a.b", no_keys, "i", "c", "n", 0, &claims),
            "id_token: not three dot-separated parts");
  const std::string none = Base64UrlEncode(R"({"alg":"none"})") + "." +
                           Base64UrlEncode(R"({"sub":"x"})") + ".";
  EXPECT_EQ(VerifyIdToken(none, no_keys, "i", "c", "n", 0, &claims),
            "id_token: alg 'none' (only RS256 is accepted)");
}

int FreeLoopbackPort() {
  boost::asio::io_context io;
  boost::asio::ip::tcp::acceptor a(
      io, boost::asio::ip::tcp::endpoint(boost::asio::ip::make_address("127.0.0.1"), 0));
  return a.local_endpoint().port();
}

std::string ReadFile(const std::filesystem::path& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// "http://127.0.0.1:PORT/path?query" -> {PORT, "/path?query"}.
std::pair<int, std::string> SplitLoopbackUrl(const std::string& url) {
  const std::string prefix = "http://127.0.0.1:";
  if (url.rfind(prefix, 0) != 0) return {0, ""};
  const size_t slash = url.find('/', prefix.size());
  return {std::stoi(url.substr(prefix.size(), slash - prefix.size())), url.substr(slash)};
}

// The test provider as a child process.
class TestIdp {
 public:
  TestIdp(const std::filesystem::path& dir, const std::string& redirect_uri) {
    const auto port_file = dir / "idp.port";
    log_ = dir / "idp.log";
    const std::string script = std::string(VES_SOURCE_DIR) + "/tests/server/oidc_test_idp.py";
    pid_ = ::fork();
    if (pid_ == 0) {
      ::execl("/usr/bin/python3", "python3", script.c_str(), "--port-file", port_file.c_str(),
              "--log", log_.c_str(), "--client-id", kClientId, "--client-secret", kClientSecret,
              "--redirect-uri", redirect_uri.c_str(), static_cast<char*>(nullptr));
      ::_exit(127);
    }
    for (int i = 0; i < 200 && port_ == 0; ++i) {
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
      std::ifstream in(port_file);
      in >> port_;
      int status = 0;
      if (::waitpid(pid_, &status, WNOHANG) == pid_) {
        pid_ = -1;
        break;
      }
    }
  }
  ~TestIdp() {
    if (pid_ > 0) {
      ::kill(pid_, SIGTERM);
      ::waitpid(pid_, nullptr, 0);
    }
  }
  int port() const { return port_; }
  std::string issuer() const { return "http://127.0.0.1:" + std::to_string(port_); }
  std::string Log() const { return ReadFile(log_); }
  void Control(const json& settings) {
    const HttpResult r = HttpCall(port_, "POST", "/control",
                                  {{"Content-Type", "application/json"}}, settings.dump());
    ASSERT_EQ(r.status, 200) << r.body;
  }

 private:
  pid_t pid_ = -1;
  int port_ = 0;
  std::filesystem::path log_;
};

// What the browser saw at the end of a sign-in.
struct Landing {
  std::string location;        // where the callback sent the browser
  std::string session_cookie;  // "ves_session=..." or ""
  std::string code;            // the provider's code, as the browser saw it
};

class OidcTest : public ::testing::Test {
 protected:
  void SetUp() override {
    if (std::system("/usr/bin/python3 -c 'import cryptography' 2>/dev/null") != 0) {
      GTEST_SKIP() << "python3-cryptography is missing (deploy/install-deps.sh installs it)";
    }
    dir_ = MakeTempDir("oidc");
    http_port_ = FreeLoopbackPort();
    redirect_uri_ = "http://127.0.0.1:" + std::to_string(http_port_) + "/api/v1/oidc/callback";
    idp_ = std::make_unique<TestIdp>(dir_, redirect_uri_);
    ASSERT_NE(idp_->port(), 0) << "the test identity provider did not start";
    ServerOptions o;
    o.http_listen = "127.0.0.1:" + std::to_string(http_port_);
    o.oidc = {idp_->issuer(), kClientId, kClientSecret, redirect_uri_, "",
              "openid email profile"};
    server_ = std::make_unique<TestServer>(o, /*log_calls=*/true);
    server_->MakeToken(StoreRole::kSupervisor, "north");  // creates the institution
    ASSERT_TRUE(server_->store()
                    .AddAccount({"dr.oidc", StoreRole::kSupervisor, "north", "", "idp-user-1", 1,
                                 0, 0})
                    .ok());
    ASSERT_TRUE(server_->store()
                    .AddAccount({"dr.mail", StoreRole::kAdmin, "north", "", "mail@hospital.org",
                                 1, 0, 0})
                    .ok());
  }
  void TearDown() override {
    server_.reset();
    idp_.reset();
    if (!dir_.empty()) std::filesystem::remove_all(dir_);
  }

  // The browser's walk: start, the provider (which signs the user in at
  // once), the callback with the provider's code and state.
  Landing SignIn(const json& idp_settings = {{"mode", "good"}}) {
    Landing out;
    idp_->Control(idp_settings);
    const HttpResult start = HttpCall(http_port_, "GET", "/api/v1/oidc/start");
    EXPECT_EQ(start.status, 302) << start.body;
    const std::string login_cookie = start.Header("set-cookie");
    EXPECT_NE(login_cookie.find("HttpOnly"), std::string::npos) << login_cookie;
    EXPECT_NE(login_cookie.find("SameSite=Lax"), std::string::npos) << login_cookie;
    auto [idp_port, authorize] = SplitLoopbackUrl(start.Header("location"));
    EXPECT_EQ(idp_port, idp_->port()) << start.Header("location");
    EXPECT_NE(authorize.find("code_challenge_method=S256"), std::string::npos) << authorize;
    const HttpResult consent = HttpCall(idp_port, "GET", authorize);
    EXPECT_EQ(consent.status, 302) << consent.body;
    const std::string back = consent.Header("location");
    EXPECT_EQ(back.rfind(redirect_uri_ + "?", 0), 0u) << back;
    callback_ = SplitLoopbackUrl(back).second;
    const size_t code_at = callback_.find("code=") + 5;
    out.code = callback_.substr(code_at, callback_.find('&', code_at) - code_at);
    login_cookie_ = login_cookie.substr(0, login_cookie.find(';'));
    const HttpResult landed =
        HttpCall(http_port_, "GET", callback_, {{"Cookie", login_cookie_}});
    EXPECT_EQ(landed.status, 302) << landed.body;
    out.location = landed.Header("location");
    for (const auto& [name, value] : landed.headers) {
      if (name == "set-cookie" && value.rfind("ves_session=", 0) == 0) {
        out.session_cookie = value.substr(0, value.find(';'));
      }
    }
    return out;
  }
  HttpResult Me(const std::string& cookie) {
    return HttpCall(http_port_, "GET", "/api/v1/me", {{"Cookie", cookie}});
  }
  std::vector<patient_db::AuditRow> Audit() {
    std::vector<patient_db::AuditRow> rows;
    for (int i = 0; i < 50; ++i) {
      auto r = server_->store().ListAudit(0, 10000);
      if (i > 0 && r.value.size() == rows.size()) break;
      rows = r.value;
      std::this_thread::sleep_for(std::chrono::milliseconds(40));
    }
    return rows;
  }

  std::filesystem::path dir_;
  int http_port_ = 0;
  std::string redirect_uri_;
  std::unique_ptr<TestIdp> idp_;
  std::unique_ptr<TestServer> server_;
  std::string callback_, login_cookie_;  // of the last SignIn
};

TEST_F(OidcTest, SignInPageLearnsThatTheProviderIsOffered) {
  const HttpResult r = HttpCall(http_port_, "GET", "/api/v1/sign-in");
  ASSERT_EQ(r.status, 200);
  EXPECT_EQ(json::parse(r.body)["oidc"], true);
}

TEST_F(OidcTest, GoodSignInMapsTheSubjectToItsAccount) {
  const Landing l = SignIn();
  EXPECT_EQ(l.location, "/trainees.html");
  ASSERT_FALSE(l.session_cookie.empty());
  const HttpResult me = Me(l.session_cookie);
  ASSERT_EQ(me.status, 200) << me.body;
  const json body = json::parse(me.body);
  EXPECT_EQ(body["label"], "dr.oidc");
  EXPECT_EQ(body["role"], "supervisor");
  EXPECT_FALSE(body["csrf_token"].get<std::string>().empty());
  // PKCE: the server sent the verifier, which the provider checked.
  const std::string idp_log = idp_->Log();
  EXPECT_NE(idp_log.find("token fields: client_id,client_secret,code,code_verifier,grant_type,"
                         "redirect_uri"),
            std::string::npos)
      << idp_log;
  bool audited = false;
  for (const auto& row : Audit()) {
    audited = audited || (row.action == "web.sign_in" && row.actor == "account:dr.oidc" &&
                          row.result == "OK" &&
                          row.target == "identity provider, from 127.0.0.1");
  }
  EXPECT_TRUE(audited);
  // The callback works once: the same code and state again are refused.
  const HttpResult replay = HttpCall(http_port_, "GET", callback_, {{"Cookie", login_cookie_}});
  EXPECT_EQ(replay.Header("location"), "/index.html?error=idp");
}

TEST_F(OidcTest, AVerifiedEmailMapsWhenNoAccountNamesTheSubject) {
  Landing l = SignIn({{"mode", "good"},
                      {"user", {{"sub", "sub-2"}, {"email", "Mail@Hospital.org"},
                                {"email_verified", true}}}});
  EXPECT_EQ(l.location, "/trainees.html");
  ASSERT_FALSE(l.session_cookie.empty());
  EXPECT_EQ(json::parse(Me(l.session_cookie).body)["label"], "dr.mail");
  // The same email, not verified by the provider: no account.
  l = SignIn({{"mode", "good"},
              {"user", {{"sub", "sub-3"}, {"email", "mail@hospital.org"},
                        {"email_verified", false}}}});
  EXPECT_EQ(l.location, "/index.html?error=no_account");
  EXPECT_TRUE(l.session_cookie.empty());
}

TEST_F(OidcTest, ForgedOrSpoiledIdTokensAreRefused) {
  LogCapture log;
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"forged", "the signature does not verify"},
      {"wrong_nonce", "nonce does not match"},
      {"wrong_aud", "aud does not name this client"},
      {"wrong_iss", "iss is not the configured issuer"},
      {"expired", "id_token: expired"},
      {"alg_none", "alg 'none'"},
      {"hs256", "alg 'HS256'"}};
  for (const auto& [mode, why] : cases) {
    const Landing l = SignIn({{"mode", mode}});
    EXPECT_EQ(l.location, "/index.html?error=idp") << mode;
    EXPECT_TRUE(l.session_cookie.empty()) << mode;
    EXPECT_NE(log.Text().find(why), std::string::npos) << mode << ": " << log.Text();
  }
  // And the provider's good token still signs in afterwards.
  EXPECT_EQ(SignIn().location, "/trainees.html");
}

TEST_F(OidcTest, AWrongStateOrAnotherBrowsersCallbackIsRefused) {
  LogCapture log;
  idp_->Control({{"mode", "good"}});
  const HttpResult start = HttpCall(http_port_, "GET", "/api/v1/oidc/start");
  const std::string cookie = start.Header("set-cookie").substr(0, start.Header("set-cookie").find(';'));
  const HttpResult consent =
      HttpCall(idp_->port(), "GET", SplitLoopbackUrl(start.Header("location")).second);
  std::string callback = SplitLoopbackUrl(consent.Header("location")).second;
  // Without the browser's cookie (another browser, or a forged link).
  HttpResult r = HttpCall(http_port_, "GET", callback);
  EXPECT_EQ(r.Header("location"), "/index.html?error=idp");
  // With the cookie but another state.
  const size_t state_at = callback.find("state=") + 6;
  std::string tampered = callback;
  tampered[state_at] = tampered[state_at] == 'A' ? 'B' : 'A';
  r = HttpCall(http_port_, "GET", tampered, {{"Cookie", cookie}});
  EXPECT_EQ(r.Header("location"), "/index.html?error=idp");
  EXPECT_NE(log.Text().find("state does not match"), std::string::npos) << log.Text();
  // The login is spent by the failed try: the right state now finds none.
  r = HttpCall(http_port_, "GET", callback, {{"Cookie", cookie}});
  EXPECT_EQ(r.Header("location"), "/index.html?error=idp");
  // The provider's own refusal.
  r = HttpCall(http_port_, "GET", "/api/v1/oidc/callback?error=access_denied&state=x",
               {{"Cookie", cookie}});
  EXPECT_EQ(r.Header("location"), "/index.html?error=idp");
}

TEST_F(OidcTest, UnknownSubjectsAndRevokedAccountsAreRefused) {
  Landing l = SignIn({{"mode", "good"}, {"user", {{"sub", "stranger"}}}});
  EXPECT_EQ(l.location, "/index.html?error=no_account");
  EXPECT_TRUE(l.session_cookie.empty());

  l = SignIn({{"mode", "good"}, {"user", {{"sub", "idp-user-1"}}}});
  ASSERT_EQ(l.location, "/trainees.html");
  ASSERT_EQ(Me(l.session_cookie).status, 200);
  ASSERT_TRUE(server_->store().RevokeAccount("dr.oidc", 1).ok());
  EXPECT_EQ(Me(l.session_cookie).status, 401);  // the next request
  l = SignIn();
  EXPECT_EQ(l.location, "/index.html?error=account");
  EXPECT_TRUE(l.session_cookie.empty());
}

TEST_F(OidcTest, NoCodeTokenOrSecretInTheLogOrTheAudit) {
  LogCapture log;
  const Landing good = SignIn();
  ASSERT_FALSE(good.session_cookie.empty());
  ASSERT_EQ(Me(good.session_cookie).status, 200);
  const Landing forged = SignIn({{"mode", "forged"}});
  ASSERT_TRUE(forged.session_cookie.empty());

  std::vector<std::string> secrets = {kClientSecret, good.code, forged.code,
                                      good.session_cookie.substr(good.session_cookie.find('=') + 1)};
  // Every ID token the provider issued.
  std::istringstream idp_log(idp_->Log());
  for (std::string line; std::getline(idp_log, line);) {
    if (line.rfind("issued id_token: ", 0) == 0) secrets.push_back(line.substr(17));
  }
  ASSERT_GE(secrets.size(), 6u);
  const std::string text = log.Text();
  EXPECT_NE(text.find("/api/v1/oidc/callback"), std::string::npos) << "the log was not captured";
  std::string rows;
  for (const auto& row : Audit()) {
    rows += row.actor + "|" + row.actor_label + "|" + row.action + "|" + row.target + "|" +
            row.result + "\n";
  }
  for (const std::string& secret : secrets) {
    ASSERT_GE(secret.size(), 16u);
    EXPECT_EQ(text.find(secret), std::string::npos) << "in the log: " << secret;
    EXPECT_EQ(rows.find(secret), std::string::npos) << "in the audit: " << secret;
  }
}

}  // namespace
}  // namespace ves::server::testing
