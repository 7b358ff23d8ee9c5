#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <map>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <unordered_map>

#include "patient_db/store.h"
#include "server/auth.h"

// People's accounts for the web pages (docs/web.md, "Accounts"): supervisors
// and admins sign in as themselves, with a password or through the
// hospital's identity provider (server/oidc.h). Stations and scripts keep
// their bearer tokens (server/auth.h).
//
// A signed-in browser holds a session secret that lives only in this
// process's memory (as a token sign-in's token does); every request with it
// reads the account from the store, so an account revoked or expired is
// refused on the next request, on every replica.
namespace ves::server {

// Passwords: scrypt (OpenSSL's EVP_PBE_scrypt), N = 2^15, r = 8, p = 1
// (32 MiB, a third of a second per hash on a busy 2-core VM), 16 random salt bytes, 32 hash bytes, stored as
// "$scrypt$ln=15,r=8,p=1$<salt base64>$<hash base64>" so the parameters can
// be raised later without breaking stored hashes.
inline constexpr size_t kMinPasswordBytes = 12;
inline constexpr size_t kMaxPasswordBytes = 128;
inline constexpr size_t kMaxUsernameBytes = 64;

// Wrong attempts (docs/web.md, "Accounts"): per account, the 5th wrong
// password within 15 minutes closes the account's password sign-in until 15
// minutes after the first of them; per source address, the 20th does the same
// for everything from that address. A success clears the account's count.
inline constexpr int kMaxWrongPerAccount = 5;
inline constexpr int kMaxWrongPerSource = 20;
inline constexpr int64_t kWrongWindowMs = 15 * 60 * 1000;
inline constexpr size_t kMaxThrottleEntries = 100000;
// scrypt costs 32 MiB: at most this many hashes at once, more answer 429.
inline constexpr int kMaxConcurrentHashes = 4;
// Signed-in account sessions per process (as browser sessions: web_api.h).
inline constexpr size_t kMaxAccountSessions = 10000;

// A new hash of `password` (throws std::runtime_error when OpenSSL fails).
std::string HashPassword(std::string_view password);
// Whether `password` matches `stored` (constant-time on the hash bytes);
// false for a malformed or empty `stored`.
bool VerifyPassword(std::string_view password, const std::string& stored);
// "" when acceptable, else why not (length in bytes, printable text).
std::string CheckNewPassword(std::string_view password);
// "" when a valid username: 1..64 of a-z 0-9 . _ @ -.
std::string CheckUsername(std::string_view username);
// "" when the account may sign in now, else why not ("account 'x' was
// revoked", "... expired").
std::string AccountRefusal(const patient_db::AccountRow& account, int64_t now_unix_ms);
// The address of a peer "ADDRESS:PORT" (as the listener names it).
std::string SourceAddress(const std::string& peer);
// The principal an account stands for: actor "account:NAME", label NAME.
Principal AccountPrincipal(const patient_db::AccountRow& account);

// The outcome of a sign-in attempt, as the HTTP layer answers it.
struct SignInOutcome {
  int http_status = 200;  // 200, 400, 401, 429, 500
  std::string code;       // "UNAUTHENTICATED", ...
  std::string message;
  int retry_after_s = 0;  // with 429
  std::string secret;     // with 200: the session secret (Bearer value)
  Principal principal;    // with 200, and with a refusal for a known account
  bool audit = false;     // whether the attempt names an account to audit
  bool ok() const { return http_status == 200; }
};

class Accounts {
 public:
  explicit Accounts(patient_db::Store* store);

  // A password sign-in from `source` (the peer address). Unknown names and
  // wrong passwords answer the same 401 and cost the same hash.
  SignInOutcome PasswordSignIn(const std::string& username, const std::string& password,
                               const std::string& source, std::chrono::seconds ttl);
  // A session for an account already authenticated elsewhere (the identity
  // provider): refused when revoked or expired.
  SignInOutcome StartSession(const patient_db::AccountRow& account, std::chrono::seconds ttl);
  // For Authenticator: whether `secret_sha256_hex` is an account session; if
  // so `*status` and `*principal` say how it resolves (the store is read on
  // every call: revocation and expiry hold from the next request).
  bool Resolve(const std::string& secret_sha256_hex, Principal* principal, AuthStatus* status);
  void EndSession(const std::string& secret);

  // Tests move the clock (throttling windows, expiry).
  void SetClockForTest(std::function<int64_t()> now_unix_ms) { now_ = std::move(now_unix_ms); }

 private:
  struct Window {
    int64_t start_unix_ms = 0;
    int wrong = 0;
    bool refusal_noted = false;  // its first refusal was audited or logged
  };
  struct Session {
    std::string username;
    int64_t expires_unix_ms = 0;
  };
  // Seconds until `key` may try again (0: it may).
  int ThrottledFor(std::unordered_map<std::string, Window>& windows, const std::string& key,
                   int limit, int64_t now) const;
  // Adds a session for `username` (mutex_ held); false when full.
  bool AddSession(const std::string& secret, const std::string& username, int64_t expires,
                  int64_t now);
  void CountWrong(std::unordered_map<std::string, Window>& windows, const std::string& key,
                  int64_t now);

  patient_db::Store* store_;
  std::function<int64_t()> now_;
  std::mutex mutex_;
  std::unordered_map<std::string, Window> wrong_by_account_;  // guarded by mutex_
  std::unordered_map<std::string, Window> wrong_by_source_;   // guarded by mutex_
  std::unordered_map<std::string, Session> sessions_;         // by secret hash; mutex_
  int hashing_ = 0;                                           // guarded by mutex_
  std::once_flag dummy_once_;
  std::string dummy_hash_;  // verified against for unknown names (same cost)
};

}  // namespace ves::server
