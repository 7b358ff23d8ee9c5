#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <map>
#include <mutex>
#include <nlohmann/json.hpp>
#include <string>
#include <string_view>
#include <vector>

// OpenID Connect sign-in against the hospital's identity provider
// (docs/web.md, "Signing in through the hospital's identity provider"):
// authorization code flow with PKCE (S256), state and nonce; the ID token's
// RS256 signature checked with the provider's published key (OpenSSL), and
// its iss, aud, exp, iat and nonce. Nothing here knows HTTP routes or
// accounts: WebApi asks for a redirect, then for the verified claims.
namespace ves::server {

struct OidcConfig {
  std::string issuer;         // e.g. https://sso.hospital.org/realms/ves; empty: no OIDC
  std::string client_id;
  std::string client_secret;  // read from a file (--oidc-client-secret-file)
  std::string redirect_uri;   // https://ves.hospital.org:8443/api/v1/oidc/callback
  std::string ca_file;        // PEM; empty: the system's CAs
  std::string scopes = "openid email profile";
  bool enabled() const { return !issuer.empty(); }
};

// Checks the configuration: every field set, https URLs (http only on a
// loopback host), bounded lengths. "" when good, else one line naming the flag.
std::string CheckOidcConfig(const OidcConfig& config);

// One HTTP(S) exchange with the identity provider: https with the peer's
// certificate and host name checked (plain http only to a loopback host), a
// 5 s timeout per step, at most 1 MiB of reply.
struct FetchResult {
  int status = 0;       // 0: transport error (`error` says what)
  std::string body;
  std::string error;
};
FetchResult Fetch(const std::string& url, const std::string& method, const std::string& form_body,
                  const std::string& ca_file);

// The claims of a verified ID token that sign-in uses.
struct IdTokenClaims {
  std::string subject;
  std::string email;  // "" unless the token says email_verified: true
  std::string name;
};

// base64url without padding (RFC 7515), strict.
std::string Base64UrlEncode(std::string_view bytes);
bool Base64UrlDecode(std::string_view text, std::string* out);

// Verifies a compact JWS ID token against the JWKS document `jwks`: alg
// RS256 only, the key by `kid` (an RSA key of at least 2048 bits), then iss,
// aud (azp when several audiences), exp and iat (60 s of clock skew) and the
// nonce. "" when good (claims filled), else why not.
std::string VerifyIdToken(const std::string& id_token, const nlohmann::json& jwks,
                          const std::string& issuer, const std::string& client_id,
                          const std::string& nonce, int64_t now_unix_s, IdTokenClaims* claims);

class OidcClient {
 public:
  explicit OidcClient(OidcConfig config);

  // A new login: the URL to send the browser to and the login id (kept in
  // the browser's ves_oidc cookie, binding the callback to this browser).
  // "" url with `error` set when the provider's discovery document cannot be
  // read.
  struct Start {
    std::string url;
    std::string login_id;
    std::string error;
  };
  Start Begin();

  // The callback: the login (by id, once), its state checked, the code
  // exchanged (with the PKCE verifier), the ID token verified.
  // "" when good, else why not (for the log: never holds a token or code).
  std::string Finish(const std::string& login_id, const std::string& state,
                     const std::string& code, IdTokenClaims* claims);

  void SetClockForTest(std::function<int64_t()> now_unix_s) { now_ = std::move(now_unix_s); }

 private:
  struct Pending {
    std::string state;
    std::string nonce;
    std::string verifier;
    int64_t created_unix_s = 0;
  };
  // Reads the discovery document once (and the JWKS; again when a token names
  // a key it lacks, at most once a minute). mutex_ not held.
  std::string Discover();
  std::string RefreshKeys(bool force);

  OidcConfig config_;
  std::function<int64_t()> now_;
  std::mutex mutex_;
  std::string authorization_endpoint_;  // guarded by mutex_
  std::string token_endpoint_;
  std::string jwks_uri_;
  nlohmann::json jwks_;
  int64_t jwks_fetched_unix_s_ = 0;
  std::map<std::string, Pending> pending_;  // by login id; guarded by mutex_
};

// Pending logins live 10 minutes; at most this many at once.
inline constexpr size_t kMaxPendingLogins = 10000;
inline constexpr int64_t kLoginTtlS = 600;

}  // namespace ves::server
