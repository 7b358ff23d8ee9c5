// WebApi: sign-in through the hospital's identity provider (docs/web.md,
// "Signing in through the hospital's identity provider"). The protocol is
// OidcClient's (server/oidc.h); here the browser is sent there and back, the
// verified identity is mapped to an account, and a browser session starts.
#include <spdlog/spdlog.h>

#include "patient_db/limits.h"
#include "server/web_api.h"
#include "server/web_reply.h"

namespace ves::server {
namespace {

HttpReply Redirect(const std::string& location) {
  HttpReply r;
  r.status = 302;
  r.content_type = "text/plain";
  r.headers.emplace_back("Location", location);
  return r;
}

}  // namespace

std::string WebApi::OidcCookie(const std::string& login_id, int64_t max_age_s) const {
  // SameSite=Lax, not Strict: the provider sends the browser back with a
  // top-level navigation from its own site, which must carry this cookie.
  // It holds only the id of a sign-in under way, useless without the
  // provider's code for the same browser.
  return std::string(kOidcCookieName) + "=" + login_id +
         "; Path=/api/v1/oidc/; Max-Age=" + std::to_string(max_age_s) + "; HttpOnly; SameSite=Lax" +
         (options_.secure_cookies ? "; Secure" : "");
}

HttpReply WebApi::OidcStart() {
  const OidcClient::Start start = oidc_->Begin();
  if (!start.error.empty()) {
    spdlog::warn("oidc: cannot start a sign-in: {}", start.error);
    return Redirect("/index.html?error=unavailable");
  }
  HttpReply r = Redirect(start.url);
  r.headers.emplace_back("Set-Cookie", OidcCookie(start.login_id, kLoginTtlS));
  return r;
}

HttpReply WebApi::OidcCallback(const HttpRequest& request,
                               const std::map<std::string, std::string>& query) {
  const std::string login_id = CookieValue(request.cookie, kOidcCookieName);
  const std::string source = SourceAddress(request.peer);
  // Every refusal: one log line saying why (never a code or token), the
  // sign-in page with a short reason, the spent login's cookie cleared.
  const auto refuse = [&](const char* reason, const std::string& why) {
    spdlog::warn("oidc: sign-in from {} refused: {}", source, why);
    HttpReply r = Redirect(std::string("/index.html?error=") + reason);
    r.headers.emplace_back("Set-Cookie", OidcCookie("", 0));
    return r;
  };
  const auto arg = [&](const char* name) {
    auto it = query.find(name);
    return it == query.end() ? std::string() : it->second;
  };
  if (!arg("error").empty()) {
    return refuse("idp", "the identity provider answered error '" +
                             patient_db::PrintableExcerpt(arg("error"), 40) + "'");
  }
  IdTokenClaims claims;
  if (std::string why = oidc_->Finish(login_id, arg("state"), arg("code"), &claims);
      !why.empty()) {
    return refuse(why.rfind("discovery", 0) == 0 || why.rfind("JWKS", 0) == 0 ? "unavailable"
                                                                              : "idp",
                  why);
  }
  // The provider's subject first; a verified email only when no account
  // names the subject (docs/web.md: which to use with which provider).
  auto account = deps_.store->FindAccountByIdentity(claims.subject);
  if (account.status.code == patient_db::StoreCode::kNotFound && !claims.email.empty()) {
    account = deps_.store->FindAccountByIdentity(claims.email);
  }
  if (!account.ok()) {
    if (account.status.code != patient_db::StoreCode::kNotFound) {
      return refuse("unavailable", account.status.message);
    }
    return refuse("no_account", "no account has idp_identity '" +
                                    patient_db::PrintableExcerpt(claims.subject, 80) + "'" +
                                    (claims.email.empty() ? "" : " or '" +
                                     patient_db::PrintableExcerpt(claims.email, 80) + "'"));
  }
  const SignInOutcome out = deps_.auth->accounts().StartSession(account.value, options_.session_ttl);
  const std::string where = "identity provider, from " + source;
  if (!out.ok()) {
    deps_.writer->SubmitAudit(MakeAudit(out.principal, "web.sign_in", where,
                                        grpc::Status(grpc::StatusCode::UNAUTHENTICATED,
                                                     out.message)));
    return refuse(out.http_status == 429 ? "busy" : "account", out.message);
  }
  HttpReply session = NewWebSession(out.secret, out.principal, where);
  if (session.status != 200) {
    deps_.auth->accounts().EndSession(out.secret);
    return refuse("busy", "too many signed-in browsers");
  }
  // The pages read the CSRF token from /api/v1/me once there.
  HttpReply r = Redirect("/trainees.html");
  for (const auto& header : session.headers) r.headers.push_back(header);
  r.headers.emplace_back("Set-Cookie", OidcCookie("", 0));
  return r;
}

}  // namespace ves::server
