#include "server/oidc.h"

#include <openssl/bn.h>
#include <openssl/core_names.h>
#include <openssl/crypto.h>
#include <openssl/evp.h>
#include <openssl/param_build.h>
#include <openssl/rand.h>
#include <openssl/sha.h>

#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/ssl.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/ssl.hpp>
#include <cctype>
#include <memory>
#include <stdexcept>

#include "patient_db/limits.h"
#include "patient_db/net_address.h"
#include "server/auth.h"

namespace ves::server {
namespace {

namespace asio = boost::asio;
namespace beast = boost::beast;
namespace http = beast::http;
using tcp = asio::ip::tcp;
using nlohmann::json;

constexpr auto kStepTimeout = std::chrono::seconds(5);
constexpr size_t kMaxReplyBytes = 1 << 20;
constexpr size_t kMaxIdTokenBytes = 16 << 10;
constexpr int64_t kClockSkewS = 60;

int64_t SystemNowS() {
  return std::chrono::duration_cast<std::chrono::seconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

struct Url {
  std::string scheme, host, port, target;
};

bool ParseUrl(const std::string& url, Url* out, std::string* error) {
  const size_t colon = url.find("://");
  if (colon == std::string::npos) return *error = "not a URL: no scheme", false;
  out->scheme = url.substr(0, colon);
  if (out->scheme != "https" && out->scheme != "http") {
    return *error = "scheme '" + out->scheme + "': must be https (or http to loopback)", false;
  }
  const size_t path = url.find('/', colon + 3);
  const std::string authority = url.substr(colon + 3, path - (colon + 3));
  out->target = path == std::string::npos ? "/" : url.substr(path);
  if (authority.empty() || authority.find('@') != std::string::npos) {
    return *error = "host: missing or with user info", false;
  }
  size_t port_colon = authority.rfind(':');
  if (authority[0] == '[') {
    const size_t close = authority.find(']');
    if (close == std::string::npos) return *error = "host: unclosed '['", false;
    out->host = authority.substr(1, close - 1);
    port_colon = authority.size() > close + 1 && authority[close + 1] == ':' ? close + 1
                                                                             : std::string::npos;
  } else {
    out->host = authority.substr(0, port_colon);
  }
  out->port = port_colon == std::string::npos ? (out->scheme == "https" ? "443" : "80")
                                              : authority.substr(port_colon + 1);
  if (out->host.empty() || out->port.empty() ||
      out->port.find_first_not_of("0123456789") != std::string::npos) {
    return *error = "host or port malformed", false;
  }
  return true;
}

bool IsLoopbackHost(const std::string& host) {
  return patient_db::IsLoopbackAddress(
      (host.find(':') != std::string::npos ? "[" + host + "]" : host) + ":1");
}

// Runs one asynchronous step to completion (its timeout set by the caller on
// the tcp_stream), so that every step is bounded in time.
template <class Start>
beast::error_code Step(asio::io_context& io, Start start) {
  beast::error_code ec;
  start([&ec](beast::error_code e, auto&&...) { ec = e; });
  io.run();
  io.restart();
  return ec;
}

template <class Stream>
FetchResult Exchange(asio::io_context& io, Stream& stream, http::request<http::string_body>& req,
                     beast::tcp_stream& lowest) {
  FetchResult out;
  lowest.expires_after(kStepTimeout);
  beast::error_code ec = Step(io, [&](auto handler) { http::async_write(stream, req, handler); });
  if (ec) return out.error = "write: " + ec.message(), out;
  beast::flat_buffer buffer;
  http::response_parser<http::string_body> parser;
  parser.body_limit(kMaxReplyBytes);
  lowest.expires_after(kStepTimeout);
  ec = Step(io, [&](auto handler) { http::async_read(stream, buffer, parser, handler); });
  if (ec) return out.error = "read: " + ec.message(), out;
  out.status = static_cast<int>(parser.get().result_int());
  out.body = parser.get().body();
  return out;
}

std::string UrlEncode(std::string_view text) {
  static const char kHex[] = "0123456789ABCDEF";
  std::string out;
  for (unsigned char c : text) {
    if (std::isalnum(c) || c == '-' || c == '.' || c == '_' || c == '~') {
      out.push_back(static_cast<char>(c));
    } else {
      out += '%';
      out += kHex[c >> 4];
      out += kHex[c & 15];
    }
  }
  return out;
}

std::string RandomUrlSafe(size_t bytes) {
  std::string raw(bytes, '\0');
  if (RAND_bytes(reinterpret_cast<unsigned char*>(raw.data()), static_cast<int>(bytes)) != 1) {
    throw std::runtime_error("OpenSSL RAND_bytes failed");
  }
  return Base64UrlEncode(raw);
}

std::string S256(const std::string& verifier) {
  unsigned char digest[SHA256_DIGEST_LENGTH];
  SHA256(reinterpret_cast<const unsigned char*>(verifier.data()), verifier.size(), digest);
  return Base64UrlEncode(std::string_view(reinterpret_cast<const char*>(digest), sizeof digest));
}

struct PkeyFree {
  void operator()(EVP_PKEY* k) const { EVP_PKEY_free(k); }
};
using Pkey = std::unique_ptr<EVP_PKEY, PkeyFree>;

// The RSA public key of a JWK ({"kty": "RSA", "n", "e"}); null when malformed.
Pkey RsaKeyOf(const json& jwk, std::string* error) {
  std::string n, e;
  if (!jwk.contains("n") || !jwk["n"].is_string() || !jwk.contains("e") || !jwk["e"].is_string() ||
      !Base64UrlDecode(jwk["n"].get<std::string>(), &n) ||
      !Base64UrlDecode(jwk["e"].get<std::string>(), &e) || n.empty() || e.empty()) {
    *error = "JWKS key: n or e missing or not base64url";
    return nullptr;
  }
  if (n.size() * 8 < 2048 || n.size() > 1024) {
    *error = "JWKS key: RSA modulus of " + std::to_string(n.size() * 8) + " bits (2048..8192)";
    return nullptr;
  }
  BIGNUM* bn_n = BN_bin2bn(reinterpret_cast<const unsigned char*>(n.data()), n.size(), nullptr);
  BIGNUM* bn_e = BN_bin2bn(reinterpret_cast<const unsigned char*>(e.data()), e.size(), nullptr);
  OSSL_PARAM_BLD* bld = OSSL_PARAM_BLD_new();
  OSSL_PARAM* params = nullptr;
  EVP_PKEY_CTX* ctx = EVP_PKEY_CTX_new_from_name(nullptr, "RSA", nullptr);
  EVP_PKEY* key = nullptr;
  if (bn_n && bn_e && bld && ctx && OSSL_PARAM_BLD_push_BN(bld, OSSL_PKEY_PARAM_RSA_N, bn_n) &&
      OSSL_PARAM_BLD_push_BN(bld, OSSL_PKEY_PARAM_RSA_E, bn_e) &&
      (params = OSSL_PARAM_BLD_to_param(bld)) != nullptr && EVP_PKEY_fromdata_init(ctx) == 1) {
    if (EVP_PKEY_fromdata(ctx, &key, EVP_PKEY_PUBLIC_KEY, params) != 1) key = nullptr;
  }
  EVP_PKEY_CTX_free(ctx);
  OSSL_PARAM_free(params);
  OSSL_PARAM_BLD_free(bld);
  BN_free(bn_n);
  BN_free(bn_e);
  if (!key) *error = "JWKS key: OpenSSL refused the RSA key";
  return Pkey(key);
}

bool VerifyRs256(EVP_PKEY* key, std::string_view signed_part, const std::string& signature) {
  EVP_MD_CTX* md = EVP_MD_CTX_new();
  bool ok = md && EVP_DigestVerifyInit(md, nullptr, EVP_sha256(), nullptr, key) == 1 &&
            EVP_DigestVerify(md, reinterpret_cast<const unsigned char*>(signature.data()),
                             signature.size(),
                             reinterpret_cast<const unsigned char*>(signed_part.data()),
                             signed_part.size()) == 1;
  EVP_MD_CTX_free(md);
  return ok;
}

std::string StringClaim(const json& claims, const char* name) {
  return claims.contains(name) && claims[name].is_string() ? claims[name].get<std::string>() : "";
}

}  // namespace

std::string Base64UrlEncode(std::string_view bytes) {
  static const char kAlphabet[] =
      "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789-_";
  std::string out;
  uint32_t acc = 0;
  int bits = 0;
  for (unsigned char c : bytes) {
    acc = (acc << 8) | c;
    bits += 8;
    while (bits >= 6) {
      bits -= 6;
      out.push_back(kAlphabet[(acc >> bits) & 63]);
    }
  }
  if (bits > 0) out.push_back(kAlphabet[(acc << (6 - bits)) & 63]);
  return out;
}

bool Base64UrlDecode(std::string_view text, std::string* out) {
  while (!text.empty() && text.back() == '=') text.remove_suffix(1);
  if (text.size() % 4 == 1) return false;
  out->clear();
  uint32_t acc = 0;
  int bits = 0;
  for (char c : text) {
    int v;
    if (c >= 'A' && c <= 'Z') v = c - 'A';
    else if (c >= 'a' && c <= 'z') v = c - 'a' + 26;
    else if (c >= '0' && c <= '9') v = c - '0' + 52;
    else if (c == '-') v = 62;
    else if (c == '_') v = 63;
    else return false;
    acc = (acc << 6) | static_cast<uint32_t>(v);
    bits += 6;
    if (bits >= 8) {
      bits -= 8;
      out->push_back(static_cast<char>((acc >> bits) & 0xff));
    }
  }
  return true;
}

std::string CheckOidcConfig(const OidcConfig& c) {
  if (!c.enabled()) return "";
  const auto url_ok = [](const std::string& url, const char* flag) -> std::string {
    Url u;
    std::string error;
    if (url.size() > 1024) return std::string(flag) + ": over 1024 characters";
    if (!ParseUrl(url, &u, &error)) return std::string(flag) + " '" + url + "': " + error;
    if (u.scheme == "http" && !IsLoopbackHost(u.host)) {
      return std::string(flag) + " '" + url + "': plain http only to a loopback host; use https";
    }
    return "";
  };
  if (std::string why = url_ok(c.issuer, "--oidc-issuer"); !why.empty()) return why;
  if (std::string why = url_ok(c.redirect_uri, "--oidc-redirect-uri"); !why.empty()) return why;
  if (c.client_id.empty() || c.client_id.size() > 255) {
    return "--oidc-client-id: must be 1..255 characters";
  }
  if (c.client_secret.empty() || c.client_secret.size() > 1024) {
    return "--oidc-client-secret-file: the secret must be 1..1024 bytes";
  }
  return "";
}

FetchResult Fetch(const std::string& url, const std::string& method, const std::string& form_body,
                  const std::string& ca_file) {
  FetchResult out;
  Url u;
  if (!ParseUrl(url, &u, &out.error)) return out;
  const bool tls = u.scheme == "https";
  if (!tls && !IsLoopbackHost(u.host)) {
    out.error = "plain http only to a loopback host";
    return out;
  }
  asio::io_context io;
  tcp::resolver resolver(io);
  beast::error_code ec;
  const auto endpoints = resolver.resolve(u.host, u.port, ec);
  if (ec) return out.error = "resolve " + u.host + ": " + ec.message(), out;
  http::request<http::string_body> req{method == "POST" ? http::verb::post : http::verb::get,
                                       u.target, 11};
  const bool default_port = u.port == (tls ? "443" : "80");
  const std::string host =
      u.host.find(':') != std::string::npos ? "[" + u.host + "]" : u.host;
  req.set(http::field::host, default_port ? host : host + ":" + u.port);
  req.set(http::field::user_agent, "ves-server");
  req.set(http::field::accept, "application/json");
  if (method == "POST") {
    req.set(http::field::content_type, "application/x-www-form-urlencoded");
    req.body() = form_body;
  }
  req.prepare_payload();
  beast::tcp_stream stream(io);
  stream.expires_after(kStepTimeout);
  ec = Step(io, [&](auto handler) { stream.async_connect(endpoints, handler); });
  if (ec) return out.error = "connect " + u.host + ":" + u.port + ": " + ec.message(), out;
  if (!tls) return Exchange(io, stream, req, stream);

  asio::ssl::context ctx(asio::ssl::context::tls_client);
  ctx.set_options(asio::ssl::context::default_workarounds | asio::ssl::context::no_sslv2 |
                  asio::ssl::context::no_sslv3 | asio::ssl::context::no_tlsv1 |
                  asio::ssl::context::no_tlsv1_1);
  ctx.set_verify_mode(asio::ssl::verify_peer);
  if (ca_file.empty()) {
    ctx.set_default_verify_paths(ec);
  } else {
    ctx.load_verify_file(ca_file, ec);
  }
  if (ec) return out.error = "TLS CA: " + ec.message(), out;
  beast::ssl_stream<beast::tcp_stream> secure(std::move(stream), ctx);
  if (!SSL_set_tlsext_host_name(secure.native_handle(), u.host.c_str())) {
    return out.error = "TLS: cannot set the server name", out;
  }
  secure.set_verify_callback(asio::ssl::host_name_verification(u.host));
  beast::get_lowest_layer(secure).expires_after(kStepTimeout);
  ec = Step(io, [&](auto handler) {
    secure.async_handshake(asio::ssl::stream_base::client, handler);
  });
  if (ec) return out.error = "TLS handshake with " + u.host + ": " + ec.message(), out;
  return Exchange(io, secure, req, beast::get_lowest_layer(secure));
}

std::string VerifyIdToken(const std::string& id_token, const json& jwks, const std::string& issuer,
                          const std::string& client_id, const std::string& nonce,
                          int64_t now_unix_s, IdTokenClaims* claims) {
  if (id_token.empty() || id_token.size() > kMaxIdTokenBytes) {
    return "id_token: empty or over " + std::to_string(kMaxIdTokenBytes) + " bytes";
  }
  const size_t dot1 = id_token.find('.');
  const size_t dot2 = dot1 == std::string::npos ? dot1 : id_token.find('.', dot1 + 1);
  if (dot2 == std::string::npos || id_token.find('.', dot2 + 1) != std::string::npos) {
    return "id_token: not three dot-separated parts";
  }
  std::string header_text, payload_text, signature;
  if (!Base64UrlDecode(std::string_view(id_token).substr(0, dot1), &header_text) ||
      !Base64UrlDecode(std::string_view(id_token).substr(dot1 + 1, dot2 - dot1 - 1),
                       &payload_text) ||
      !Base64UrlDecode(std::string_view(id_token).substr(dot2 + 1), &signature)) {
    return "id_token: a part is not base64url";
  }
  const json header = json::parse(header_text, nullptr, false);
  const json payload = json::parse(payload_text, nullptr, false);
  if (!header.is_object() || !payload.is_object()) return "id_token: header or payload not JSON";
  // The algorithm is fixed here, never taken from the token ("none", HS256
  // with the public key as secret, ...).
  if (StringClaim(header, "alg") != "RS256") {
    return "id_token: alg '" + patient_db::PrintableExcerpt(StringClaim(header, "alg"), 20) +
           "' (only RS256 is accepted)";
  }
  const std::string kid = StringClaim(header, "kid");
  const json* key = nullptr;
  int rsa_keys = 0;
  if (jwks.is_object() && jwks.contains("keys") && jwks["keys"].is_array()) {
    for (const json& k : jwks["keys"]) {
      if (!k.is_object() || StringClaim(k, "kty") != "RSA") continue;
      if (k.contains("use") && StringClaim(k, "use") != "sig") continue;
      ++rsa_keys;
      if (StringClaim(k, "kid") == kid) key = &k;
    }
    // A provider with one key may leave kid out.
    if (!key && kid.empty() && rsa_keys == 1) {
      for (const json& k : jwks["keys"]) {
        if (k.is_object() && StringClaim(k, "kty") == "RSA") key = &k;
      }
    }
  }
  if (!key) return "id_token: no RSA signing key with kid '" + patient_db::PrintableExcerpt(kid, 64) + "'";
  std::string key_error;
  Pkey pkey = RsaKeyOf(*key, &key_error);
  if (!pkey) return key_error;
  if (!VerifyRs256(pkey.get(), std::string_view(id_token).substr(0, dot2), signature)) {
    return "id_token: the signature does not verify with the provider's key";
  }
  if (StringClaim(payload, "iss") != issuer) return "id_token: iss is not the configured issuer";
  bool audience = false;
  if (payload.contains("aud") && payload["aud"].is_string()) {
    audience = payload["aud"] == client_id;
  } else if (payload.contains("aud") && payload["aud"].is_array()) {
    for (const json& a : payload["aud"]) audience = audience || (a.is_string() && a == client_id);
    // Several audiences: the token must have been issued to this client.
    if (audience && payload["aud"].size() > 1) audience = StringClaim(payload, "azp") == client_id;
  }
  if (!audience) return "id_token: aud does not name this client";
  if (!payload.contains("exp") || !payload["exp"].is_number()) return "id_token: no exp";
  if (payload["exp"].get<double>() + kClockSkewS < static_cast<double>(now_unix_s)) {
    return "id_token: expired";
  }
  if (payload.contains("iat") && payload["iat"].is_number() &&
      payload["iat"].get<double>() > static_cast<double>(now_unix_s + kClockSkewS)) {
    return "id_token: issued in the future (iat)";
  }
  const std::string token_nonce = StringClaim(payload, "nonce");
  if (token_nonce.size() != nonce.size() ||
      CRYPTO_memcmp(token_nonce.data(), nonce.data(), nonce.size()) != 0) {
    return "id_token: nonce does not match this sign-in";
  }
  claims->subject = StringClaim(payload, "sub");
  if (claims->subject.empty() || claims->subject.size() > 255) {
    return "id_token: sub missing or over 255 bytes";
  }
  claims->email.clear();
  if (payload.contains("email_verified") && payload["email_verified"] == true) {
    claims->email = StringClaim(payload, "email");
    for (char& c : claims->email) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    if (claims->email.size() > 255) claims->email.clear();
  }
  claims->name = patient_db::PrintableExcerpt(StringClaim(payload, "name"), 120);
  return "";
}

OidcClient::OidcClient(OidcConfig config) : config_(std::move(config)), now_(SystemNowS) {}

std::string OidcClient::Discover() {
  {
    std::lock_guard lock(mutex_);
    if (!token_endpoint_.empty()) return "";
  }
  std::string url = config_.issuer;
  if (!url.empty() && url.back() == '/') url.pop_back();
  const FetchResult r = Fetch(url + "/.well-known/openid-configuration", "GET", "", config_.ca_file);
  if (r.status != 200) {
    return "discovery document: " + (r.status == 0 ? r.error : "HTTP " + std::to_string(r.status));
  }
  const json doc = json::parse(r.body, nullptr, false);
  if (!doc.is_object()) return "discovery document: not a JSON object";
  if (StringClaim(doc, "issuer") != config_.issuer) {
    return "discovery document: issuer '" +
           patient_db::PrintableExcerpt(StringClaim(doc, "issuer"), 200) +
           "' is not --oidc-issuer '" + config_.issuer + "'";
  }
  const std::string authorization = StringClaim(doc, "authorization_endpoint");
  const std::string token = StringClaim(doc, "token_endpoint");
  const std::string jwks = StringClaim(doc, "jwks_uri");
  for (const auto& [name, value] : {std::pair<const char*, std::string>{"authorization_endpoint", authorization},
                                    {"token_endpoint", token},
                                    {"jwks_uri", jwks}}) {
    Url u;
    std::string error;
    if (value.empty() || value.size() > 1024 || !ParseUrl(value, &u, &error) ||
        (u.scheme == "http" && !IsLoopbackHost(u.host))) {
      return std::string("discovery document: ") + name + " missing or not an https URL";
    }
  }
  if (doc.contains("code_challenge_methods_supported") &&
      doc["code_challenge_methods_supported"].is_array()) {
    bool s256 = false;
    for (const json& m : doc["code_challenge_methods_supported"]) s256 = s256 || m == "S256";
    if (!s256) return "discovery document: the provider does not offer PKCE S256";
  }
  std::lock_guard lock(mutex_);
  authorization_endpoint_ = authorization;
  token_endpoint_ = token;
  jwks_uri_ = jwks;
  return "";
}

std::string OidcClient::RefreshKeys(bool force) {
  std::string uri;
  {
    std::lock_guard lock(mutex_);
    const int64_t now = now_();
    if (!jwks_.is_null() && (!force || now - jwks_fetched_unix_s_ < 60)) return "";
    uri = jwks_uri_;
  }
  const FetchResult r = Fetch(uri, "GET", "", config_.ca_file);
  if (r.status != 200) return "JWKS: " + (r.status == 0 ? r.error : "HTTP " + std::to_string(r.status));
  json keys = json::parse(r.body, nullptr, false);
  if (!keys.is_object() || !keys.contains("keys") || !keys["keys"].is_array()) {
    return "JWKS: not {\"keys\": [...]}";
  }
  std::lock_guard lock(mutex_);
  jwks_ = std::move(keys);
  jwks_fetched_unix_s_ = now_();
  return "";
}

OidcClient::Start OidcClient::Begin() {
  Start out;
  if (std::string why = Discover(); !why.empty()) {
    out.error = why;
    return out;
  }
  Pending p;
  p.state = RandomUrlSafe(32);
  p.nonce = RandomUrlSafe(32);
  p.verifier = RandomUrlSafe(48);  // 64 characters (RFC 7636: 43..128)
  p.created_unix_s = now_();
  out.login_id = NewToken();
  std::string endpoint;
  {
    std::lock_guard lock(mutex_);
    for (auto it = pending_.begin(); it != pending_.end();) {
      it = it->second.created_unix_s + kLoginTtlS <= p.created_unix_s ? pending_.erase(it)
                                                                       : std::next(it);
    }
    if (pending_.size() >= kMaxPendingLogins) {
      out.error = "too many sign-ins under way; try again later";
      return out;
    }
    pending_[out.login_id] = p;
    endpoint = authorization_endpoint_;
  }
  out.url = endpoint + (endpoint.find('?') == std::string::npos ? "?" : "&") +
            "response_type=code&client_id=" + UrlEncode(config_.client_id) +
            "&redirect_uri=" + UrlEncode(config_.redirect_uri) + "&scope=" +
            UrlEncode(config_.scopes) + "&state=" + p.state + "&nonce=" + p.nonce +
            "&code_challenge=" + S256(p.verifier) + "&code_challenge_method=S256";
  return out;
}

std::string OidcClient::Finish(const std::string& login_id, const std::string& state,
                               const std::string& code, IdTokenClaims* claims) {
  Pending p;
  {
    std::lock_guard lock(mutex_);
    auto it = pending_.find(login_id);
    if (login_id.empty() || it == pending_.end()) {
      return "no sign-in under way in this browser (the ves_oidc cookie is missing or spent)";
    }
    p = it->second;
    pending_.erase(it);  // one use, whatever happens next
  }
  if (p.created_unix_s + kLoginTtlS <= now_()) return "the sign-in took over 10 minutes";
  if (state.size() != p.state.size() ||
      CRYPTO_memcmp(state.data(), p.state.data(), state.size()) != 0) {
    return "state does not match this browser's sign-in";
  }
  if (code.empty() || code.size() > 2048) return "code: missing or over 2048 bytes";
  std::string token_endpoint;
  {
    std::lock_guard lock(mutex_);
    token_endpoint = token_endpoint_;
  }
  const std::string form = "grant_type=authorization_code&code=" + UrlEncode(code) +
                           "&redirect_uri=" + UrlEncode(config_.redirect_uri) +
                           "&code_verifier=" + p.verifier +
                           "&client_id=" + UrlEncode(config_.client_id) +
                           "&client_secret=" + UrlEncode(config_.client_secret);
  const FetchResult r = Fetch(token_endpoint, "POST", form, config_.ca_file);
  if (r.status != 200) {
    // The provider's error code is short and safe to log; its body is not shown.
    const json err = json::parse(r.body, nullptr, false);
    const std::string what = err.is_object() ? StringClaim(err, "error") : "";
    return "token endpoint: " +
           (r.status == 0 ? r.error
                          : "HTTP " + std::to_string(r.status) +
                                (what.empty() ? "" : " " + patient_db::PrintableExcerpt(what, 40)));
  }
  const json reply = json::parse(r.body, nullptr, false);
  if (!reply.is_object() || !reply.contains("id_token") || !reply["id_token"].is_string()) {
    return "token endpoint: the reply has no id_token";
  }
  const std::string id_token = reply["id_token"].get<std::string>();
  if (std::string why = RefreshKeys(false); !why.empty()) return why;
  json jwks;
  {
    std::lock_guard lock(mutex_);
    jwks = jwks_;
  }
  std::string why = VerifyIdToken(id_token, jwks, config_.issuer, config_.client_id, p.nonce,
                                  now_(), claims);
  if (why.rfind("id_token: no RSA signing key", 0) == 0) {
    // The provider may have rotated its keys: read them again (at most once a minute).
    if (RefreshKeys(true).empty()) {
      std::lock_guard lock(mutex_);
      jwks = jwks_;
    }
    why = VerifyIdToken(id_token, jwks, config_.issuer, config_.client_id, p.nonce, now_(), claims);
  }
  return why;
}

}  // namespace ves::server
