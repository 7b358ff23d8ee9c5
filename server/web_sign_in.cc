// WebApi: browser sessions (docs/web.md, "Signing in"): sign-in with a token
// or an account's password, the session cookie and its CSRF token, sign-out;
// and their routes.
#include <openssl/crypto.h>

#include <nlohmann/json.hpp>

#include "patient_db/limits.h"
#include "server/pipeline.h"
#include "server/web_api.h"
#include "server/web_reply.h"
#include "server/web_routes.h"

namespace ves::server {

using grpc::Status;
using grpc::StatusCode;
using nlohmann::json;

namespace {

constexpr const char* kCookieName = "ves_session";

bool ConstantTimeEquals(const std::string& a, const std::string& b) {
  return a.size() == b.size() && CRYPTO_memcmp(a.data(), b.data(), a.size()) == 0;
}

// GET: which ways of signing in this server offers (the sign-in page).
HttpReply SignInWays(WebCall& call) {
  return JsonReply(200, {{"token", true}, {"password", true}, {"oidc", call.api.oidc_enabled()}});
}
HttpReply SignInRoute(WebCall& call) { return call.api.SignIn(call.request); }
HttpReply SignOutRoute(WebCall& call) { return call.api.SignOut(call); }

HttpReply OidcStartRoute(WebCall& call) {
  if (!call.api.oidc_enabled()) {
    return Error(404, "NOT_FOUND", "no identity provider is configured (ves-server --oidc-issuer)");
  }
  return call.api.OidcStart();
}

HttpReply OidcCallbackRoute(WebCall& call) {
  if (!call.api.oidc_enabled()) {
    return Error(404, "NOT_FOUND", "no identity provider is configured (ves-server --oidc-issuer)");
  }
  return call.api.OidcCallback(call.request, call.query);
}

}  // namespace

// Signing in is public: it authenticates the caller itself (a token, a
// password or the identity provider's answer) and audits the outcome.
std::vector<WebRoute> SignInRoutes() {
  return {{"GET", "/api/v1/sign-in", {}, &SignInWays},
          {"POST", "/api/v1/sign-in", {}, &SignInRoute},
          {"POST", "/api/v1/sign-out", kEveryRole, &SignOutRoute},
          {"GET", "/api/v1/oidc/start", {}, &OidcStartRoute},
          {"GET", "/api/v1/oidc/callback", {}, &OidcCallbackRoute}};
}

std::string WebApi::AuthorizationOf(const HttpRequest& request, bool* csrf_ok,
                                    std::string* session_id) {
  *csrf_ok = true;
  if (!request.authorization.empty()) return request.authorization;  // scripts: Bearer
  const std::string sid = CookieValue(request.cookie, kCookieName);
  if (sid.empty()) return {};
  std::lock_guard lock(mutex_);
  auto it = sessions_.find(sid);
  if (it == sessions_.end()) return {};
  if (it->second.expires_unix_ms <= NowUnixMs()) {
    sessions_.erase(it);
    return {};
  }
  *session_id = sid;
  // A cookie rides along on any request the browser makes: a state change
  // must also carry the token only this origin's pages can read.
  *csrf_ok =
      request.method == "GET" || ConstantTimeEquals(request.csrf_token, it->second.csrf_token);
  return "Bearer " + it->second.token;
}

HttpReply WebApi::SignIn(const HttpRequest& request) {
  json body = json::parse(request.body, nullptr, false);
  if (body.is_object() && body.contains("username")) {
    // A person's account (server/accounts.h): the session holds a secret of
    // its own, resolved against the account on every request.
    if (!body["username"].is_string() || !body.contains("password") ||
        !body["password"].is_string()) {
      return Error(400, "INVALID_ARGUMENT",
                   "body: must be {\"username\": \"...\", \"password\": \"...\"}");
    }
    const SignInOutcome out = deps_.auth->accounts().PasswordSignIn(
        body["username"].get<std::string>(), body["password"].get<std::string>(), request.peer,
        options_.session_ttl);
    return StartWebSession(out, request.peer);
  }
  if (!body.is_object() || !body.contains("token") || !body["token"].is_string()) {
    return Error(400, "INVALID_ARGUMENT", "body: must be {\"token\": \"<token>\"}");
  }
  const std::string token = body["token"].get<std::string>();
  if (token.empty() || token.size() > 128) {
    return Error(400, "INVALID_ARGUMENT", "token: must be 1..128 characters");
  }
  Principal who;
  const AuthStatus a = deps_.auth->Authenticate("Bearer " + token, &who);
  if (!a.ok()) {
    return Error(a.code == AuthCode::kUnauthenticated ? 401 : 500,
                 a.code == AuthCode::kUnauthenticated ? "UNAUTHENTICATED" : "INTERNAL", a.message);
  }
  return NewWebSession(token, who, "");
}

HttpReply WebApi::StartWebSession(const SignInOutcome& out, const std::string& peer) {
  // The source address is the audit row's target: who tried from where.
  const std::string where = "from " + SourceAddress(peer);
  if (!out.ok()) {
    if (out.audit) {
      deps_.writer->SubmitAudit(MakeAudit(out.principal, "web.sign_in", where,
                                          Status(out.http_status == 429
                                                     ? StatusCode::RESOURCE_EXHAUSTED
                                                     : StatusCode::UNAUTHENTICATED,
                                                 out.message)));
    }
    HttpReply r = Error(out.http_status, out.code, out.message);
    if (out.retry_after_s > 0) r.headers.emplace_back("Retry-After", std::to_string(out.retry_after_s));
    return r;
  }
  HttpReply r = NewWebSession(out.secret, out.principal, where);
  if (r.status != 200) deps_.auth->accounts().EndSession(out.secret);
  return r;
}

HttpReply WebApi::NewWebSession(const std::string& token, const Principal& who,
                                const std::string& audit_target) {
  WebSession session{
      token, NewToken(),
      NowUnixMs() +
          std::chrono::duration_cast<std::chrono::milliseconds>(options_.session_ttl).count()};
  const std::string sid = NewToken();
  {
    std::lock_guard lock(mutex_);
    const int64_t now = NowUnixMs();
    for (auto it = sessions_.begin(); it != sessions_.end();) {
      it = it->second.expires_unix_ms <= now ? sessions_.erase(it) : std::next(it);
    }
    if (sessions_.size() >= kMaxWebSessions) {
      return Error(429, "RESOURCE_EXHAUSTED", "too many signed-in browsers; try again later");
    }
    sessions_[sid] = session;
  }
  deps_.writer->SubmitAudit(MakeAudit(who, "web.sign_in", audit_target, Status::OK));
  HttpReply r = JsonReply(200, {{"csrf_token", session.csrf_token},
                                {"role", patient_db::RoleName(who.role)},
                                {"institution", who.institution},
                                {"label", who.label},
                                {"expires_unix_ms", session.expires_unix_ms}});
  r.headers.emplace_back("Set-Cookie", std::string(kCookieName) + "=" + sid + "; Path=/; Max-Age=" +
                                           std::to_string(options_.session_ttl.count()) +
                                           "; HttpOnly; SameSite=Strict" +
                                           (options_.secure_cookies ? "; Secure" : ""));
  return r;
}

HttpReply WebApi::SignOut(WebCall& call) {
  if (call.session_id.empty()) return Error(401, "UNAUTHENTICATED", "not signed in");
  if (!call.csrf_ok) return Error(403, "PERMISSION_DENIED", "X-CSRF-Token header missing or wrong");
  // Audited when the session still names a principal; it ends either way.
  static const CallSpec spec{"web.sign_out", kEveryRole, "sign out"};
  if (call.Admit(v1::ListTraineesRequest()).ok()) {
    RunCall(deps_, call.who, spec, "", [] { return Status::OK; });
  }
  {
    std::lock_guard lock(mutex_);
    auto it = sessions_.find(call.session_id);
    if (it != sessions_.end()) {
      deps_.auth->accounts().EndSession(it->second.token);
      sessions_.erase(it);
    }
  }
  HttpReply r = JsonReply(200, {{"signed_out", true}});
  r.headers.emplace_back("Set-Cookie", std::string(kCookieName) +
                                           "=; Path=/; Max-Age=0; HttpOnly; SameSite=Strict" +
                                           (options_.secure_cookies ? "; Secure" : ""));
  return r;
}

}  // namespace ves::server
