#include "server/accounts.h"

#include <openssl/crypto.h>
#include <openssl/evp.h>
#include <openssl/rand.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <cstdio>
#include <stdexcept>
#include <vector>

namespace ves::server {
namespace {

constexpr uint64_t kScryptLogN = 15;
constexpr uint64_t kScryptR = 8;
constexpr uint64_t kScryptP = 1;
constexpr size_t kSaltBytes = 16;
constexpr size_t kHashBytes = 32;
constexpr std::string_view kScheme = "$scrypt$";

int64_t SystemNowMs() {
  return std::chrono::duration_cast<std::chrono::milliseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

std::string Base64(const unsigned char* bytes, size_t n) {
  std::string out(4 * ((n + 2) / 3) + 1, '\0');
  const int len = EVP_EncodeBlock(reinterpret_cast<unsigned char*>(out.data()), bytes,
                                  static_cast<int>(n));
  out.resize(len);
  return out;
}

// Strict base64 of exactly `want` bytes.
bool Unbase64(std::string_view text, size_t want, std::vector<unsigned char>* out) {
  if (text.size() != 4 * ((want + 2) / 3)) return false;
  out->assign(3 * text.size() / 4 + 1, 0);
  const int len = EVP_DecodeBlock(out->data(), reinterpret_cast<const unsigned char*>(text.data()),
                                  static_cast<int>(text.size()));
  if (len < 0) return false;
  out->resize(want);  // EVP_DecodeBlock counts the padding as zero bytes
  return true;
}

bool Scrypt(std::string_view password, const unsigned char* salt, size_t salt_len, uint64_t log_n,
            uint64_t r, uint64_t p, unsigned char* out, size_t out_len) {
  // Memory is 128 * N * r bytes; the limit leaves room for it and no more.
  const uint64_t max_mem = 2 * 128 * (uint64_t{1} << log_n) * r;
  return EVP_PBE_scrypt(password.data(), password.size(), salt, salt_len, uint64_t{1} << log_n, r,
                        p, max_mem, out, out_len) == 1;
}

SignInOutcome Refusal(int status, const char* code, std::string message) {
  SignInOutcome out;
  out.http_status = status;
  out.code = code;
  out.message = std::move(message);
  return out;
}

}  // namespace

std::string SourceAddress(const std::string& peer) {
  // The port changes per connection; the address is what is throttled.
  const size_t colon = peer.rfind(':');
  return colon == std::string::npos ? peer : peer.substr(0, colon);
}

std::string HashPassword(std::string_view password) {
  unsigned char salt[kSaltBytes];
  unsigned char hash[kHashBytes];
  if (RAND_bytes(salt, sizeof salt) != 1 ||
      !Scrypt(password, salt, sizeof salt, kScryptLogN, kScryptR, kScryptP, hash, sizeof hash)) {
    throw std::runtime_error("cannot hash a password: OpenSSL scrypt failed");
  }
  return std::string(kScheme) + "ln=" + std::to_string(kScryptLogN) +
         ",r=" + std::to_string(kScryptR) + ",p=" + std::to_string(kScryptP) + "$" +
         Base64(salt, sizeof salt) + "$" + Base64(hash, sizeof hash);
}

bool VerifyPassword(std::string_view password, const std::string& stored) {
  if (stored.rfind(kScheme, 0) != 0) return false;
  unsigned long long log_n = 0, r = 0, p = 0;
  char salt_b64[64] = {0}, hash_b64[64] = {0};
  if (std::sscanf(stored.c_str() + kScheme.size(), "ln=%llu,r=%llu,p=%llu$%63[^$]$%63s", &log_n,
                  &r, &p, salt_b64, hash_b64) != 5) {
    return false;
  }
  // Bounds on what a stored string may ask for: no hash may cost more than
  // 16 times the current one.
  if (log_n < 10 || log_n > 20 || r < 1 || r > 32 || p < 1 || p > 4) return false;
  std::vector<unsigned char> salt, want;
  if (!Unbase64(salt_b64, kSaltBytes, &salt) || !Unbase64(hash_b64, kHashBytes, &want)) {
    return false;
  }
  unsigned char got[kHashBytes];
  if (!Scrypt(password, salt.data(), salt.size(), log_n, r, p, got, sizeof got)) return false;
  return CRYPTO_memcmp(got, want.data(), kHashBytes) == 0;
}

std::string CheckNewPassword(std::string_view password) {
  if (password.size() < kMinPasswordBytes || password.size() > kMaxPasswordBytes) {
    return "password: " + std::to_string(password.size()) + " bytes; must be " +
           std::to_string(kMinPasswordBytes) + ".." + std::to_string(kMaxPasswordBytes);
  }
  for (unsigned char c : password) {
    if (c < 0x20 || c == 0x7f) return "password: must not hold control characters";
  }
  return "";
}

std::string CheckUsername(std::string_view username) {
  if (username.empty() || username.size() > kMaxUsernameBytes) {
    return "username: must be 1.." + std::to_string(kMaxUsernameBytes) + " characters";
  }
  for (char c : username) {
    const bool ok = (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '.' || c == '_' ||
                    c == '@' || c == '-';
    if (!ok) return "username: only a-z, 0-9, '.', '_', '@' and '-'";
  }
  return "";
}

std::string AccountRefusal(const patient_db::AccountRow& account, int64_t now_unix_ms) {
  if (account.revoked_unix_ms != 0) return "account '" + account.username + "' was revoked";
  if (account.expires_unix_ms != 0 && account.expires_unix_ms <= now_unix_ms) {
    return "account '" + account.username + "' has expired";
  }
  if (account.role != patient_db::StoreRole::kAdmin &&
      account.role != patient_db::StoreRole::kSupervisor) {
    return "account '" + account.username + "' is not an admin or supervisor";
  }
  return "";
}

Principal AccountPrincipal(const patient_db::AccountRow& account) {
  Principal p;
  p.role = account.role;
  p.institution = account.institution;
  p.token_id = "account:" + account.username;
  p.label = account.username;
  return p;
}

Accounts::Accounts(patient_db::Store* store)
    : store_(store), now_(SystemNowMs) {}

bool Accounts::AddSession(const std::string& secret, const std::string& username, int64_t expires,
                          int64_t now) {
  for (auto it = sessions_.begin(); it != sessions_.end();) {
    it = it->second.expires_unix_ms <= now ? sessions_.erase(it) : std::next(it);
  }
  if (sessions_.size() >= kMaxAccountSessions) return false;
  sessions_[Sha256Hex(secret)] = {username, expires};
  return true;
}

int Accounts::ThrottledFor(std::unordered_map<std::string, Window>& windows,
                           const std::string& key, int limit, int64_t now) const {
  auto it = windows.find(key);
  if (it == windows.end()) return 0;
  const int64_t end = it->second.start_unix_ms + kWrongWindowMs;
  if (end <= now) {
    windows.erase(it);
    return 0;
  }
  if (it->second.wrong < limit) return 0;
  return static_cast<int>((end - now + 999) / 1000);
}

void Accounts::CountWrong(std::unordered_map<std::string, Window>& windows,
                          const std::string& key, int64_t now) {
  if (windows.size() >= kMaxThrottleEntries && windows.find(key) == windows.end()) {
    for (auto it = windows.begin(); it != windows.end();) {
      it = it->second.start_unix_ms + kWrongWindowMs <= now ? windows.erase(it) : std::next(it);
    }
    // Still full: an attack from very many addresses. The oldest windows go
    // rather than the new one, so the newest attempts stay counted.
    while (windows.size() >= kMaxThrottleEntries) {
      auto oldest = windows.begin();
      for (auto it = windows.begin(); it != windows.end(); ++it) {
        if (it->second.start_unix_ms < oldest->second.start_unix_ms) oldest = it;
      }
      windows.erase(oldest);
    }
  }
  Window& w = windows[key];
  if (w.wrong == 0 || w.start_unix_ms + kWrongWindowMs <= now) w = {now, 0};
  ++w.wrong;
}

SignInOutcome Accounts::PasswordSignIn(const std::string& username, const std::string& password,
                                       const std::string& source_peer, std::chrono::seconds ttl) {
  if (std::string why = CheckUsername(username); !why.empty()) {
    return Refusal(400, "INVALID_ARGUMENT", why);
  }
  if (password.empty() || password.size() > kMaxPasswordBytes) {
    return Refusal(400, "INVALID_ARGUMENT",
                   "password: must be 1.." + std::to_string(kMaxPasswordBytes) + " bytes");
  }
  const std::string source = SourceAddress(source_peer);
  bool first_refusal = false;  // the first refused attempt of an account's window
  {
    std::lock_guard lock(mutex_);
    const int64_t now = now_();
    const int by_source = ThrottledFor(wrong_by_source_, source, kMaxWrongPerSource, now);
    const int by_account = ThrottledFor(wrong_by_account_, username, kMaxWrongPerAccount, now);
    if (by_source > 0 || by_account > 0) {
      Window& w = by_account > 0 ? wrong_by_account_[username] : wrong_by_source_[source];
      first_refusal = !w.refusal_noted;
      w.refusal_noted = true;
      if (first_refusal && by_account == 0) {
        spdlog::warn("sign-in: address {} throttled after {} wrong attempts", source,
                     kMaxWrongPerSource);
      }
      first_refusal = first_refusal && by_account > 0;
      SignInOutcome out = Refusal(
          429, "RESOURCE_EXHAUSTED",
          by_account > 0 ? "too many wrong passwords for this account; try again later"
                         : "too many wrong passwords from this address; try again later");
      out.retry_after_s = std::max(by_source, by_account);
      if (first_refusal) {
        // One audit row per closed window, not one per hammering attempt.
        auto found = store_->GetAccount(username);
        if (found.ok()) {
          out.principal = AccountPrincipal(found.value);
          out.audit = true;
        }
      }
      return out;
    }
    if (hashing_ >= kMaxConcurrentHashes) {
      SignInOutcome out =
          Refusal(429, "RESOURCE_EXHAUSTED", "too many sign-ins at once; try again");
      out.retry_after_s = 1;
      return out;
    }
    ++hashing_;
  }
  std::call_once(dummy_once_, [this] { dummy_hash_ = HashPassword("no account has this"); });
  auto found = store_->GetAccount(username);
  const bool known = found.ok();
  // An unknown name costs the same hash as a known one: the answer's time
  // does not tell which names exist.
  const bool match =
      VerifyPassword(password, known && !found.value.password_hash.empty()
                                   ? found.value.password_hash
                                   : dummy_hash_) &&
      known && !found.value.password_hash.empty();
  const int64_t now = now_();
  std::lock_guard lock(mutex_);
  --hashing_;
  if (!known && found.status.code != patient_db::StoreCode::kNotFound) {
    return Refusal(500, "INTERNAL", found.status.message);
  }
  if (!match) {
    CountWrong(wrong_by_source_, source, now);
    CountWrong(wrong_by_account_, username, now);
    SignInOutcome out = Refusal(401, "UNAUTHENTICATED", "wrong username or password");
    if (known) {
      out.principal = AccountPrincipal(found.value);
      out.audit = true;
    }
    return out;
  }
  wrong_by_account_.erase(username);
  if (std::string why = AccountRefusal(found.value, now); !why.empty()) {
    SignInOutcome out = Refusal(401, "UNAUTHENTICATED", why);
    out.principal = AccountPrincipal(found.value);
    out.audit = true;
    return out;
  }
  const int64_t expires = now + std::chrono::duration_cast<std::chrono::milliseconds>(ttl).count();
  SignInOutcome out;
  out.secret = NewToken();
  out.principal = AccountPrincipal(found.value);
  out.audit = true;
  if (!AddSession(out.secret, username, expires, now)) {
    SignInOutcome full = Refusal(429, "RESOURCE_EXHAUSTED", "too many signed-in browsers; try again later");
    full.retry_after_s = 60;
    return full;
  }
  return out;
}

SignInOutcome Accounts::StartSession(const patient_db::AccountRow& account,
                                     std::chrono::seconds ttl) {
  const int64_t now = now_();
  if (std::string why = AccountRefusal(account, now); !why.empty()) {
    SignInOutcome out = Refusal(401, "UNAUTHENTICATED", why);
    out.principal = AccountPrincipal(account);
    out.audit = true;
    return out;
  }
  SignInOutcome out;
  out.secret = NewToken();
  out.principal = AccountPrincipal(account);
  out.audit = true;
  const int64_t expires = now + std::chrono::duration_cast<std::chrono::milliseconds>(ttl).count();
  std::lock_guard lock(mutex_);
  if (!AddSession(out.secret, account.username, expires, now)) {
    SignInOutcome full = Refusal(429, "RESOURCE_EXHAUSTED", "too many signed-in browsers; try again later");
    full.retry_after_s = 60;
    return full;
  }
  return out;
}

bool Accounts::Resolve(const std::string& secret_sha256_hex, Principal* principal,
                       AuthStatus* status) {
  std::string username;
  {
    std::lock_guard lock(mutex_);
    auto it = sessions_.find(secret_sha256_hex);
    if (it == sessions_.end()) return false;
    if (it->second.expires_unix_ms <= now_()) {
      sessions_.erase(it);
      *status = {AuthCode::kUnauthenticated, "session expired"};
      return true;
    }
    username = it->second.username;
  }
  auto found = store_->GetAccount(username);
  if (!found.ok()) {
    *status = found.status.code == patient_db::StoreCode::kNotFound
                  ? AuthStatus{AuthCode::kUnauthenticated, "no account '" + username + "'"}
                  : AuthStatus{AuthCode::kInternal, found.status.message};
    return true;
  }
  if (std::string why = AccountRefusal(found.value, now_()); !why.empty()) {
    std::lock_guard lock(mutex_);
    sessions_.erase(secret_sha256_hex);
    *status = {AuthCode::kUnauthenticated, why};
    return true;
  }
  *principal = AccountPrincipal(found.value);
  *status = {};
  return true;
}

void Accounts::EndSession(const std::string& secret) {
  std::lock_guard lock(mutex_);
  sessions_.erase(Sha256Hex(secret));
}

}  // namespace ves::server
