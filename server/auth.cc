#include "server/auth.h"

#include <openssl/rand.h>

#include <stdexcept>

#include "server/accounts.h"

namespace ves::server {
namespace {

std::string Hex(const unsigned char* bytes, size_t n) {
  static const char kDigits[] = "0123456789abcdef";
  std::string out(2 * n, '0');
  for (size_t i = 0; i < n; ++i) {
    out[2 * i] = kDigits[bytes[i] >> 4];
    out[2 * i + 1] = kDigits[bytes[i] & 0xf];
  }
  return out;
}

AuthStatus Denied(const std::string& message) {
  return {AuthCode::kPermissionDenied, message};
}

}  // namespace

std::string NewToken() {
  unsigned char bytes[32];
  if (RAND_bytes(bytes, sizeof bytes) != 1) {
    throw std::runtime_error("cannot generate a token: OpenSSL RAND_bytes failed");
  }
  return Hex(bytes, sizeof bytes);
}

std::string TokenIdOf(const std::string& token_sha256_hex) {
  return token_sha256_hex.substr(0, 12);
}

Authenticator::Authenticator(patient_db::Store* store)
    : store_(store), accounts_(std::make_unique<Accounts>(store)) {}

Authenticator::~Authenticator() = default;

AuthStatus Authenticator::Authenticate(std::string_view authorization, Principal* principal) {
  constexpr std::string_view kBearer = "Bearer ";
  if (authorization.empty()) {
    return {AuthCode::kUnauthenticated, "missing 'authorization: Bearer <token>' metadata"};
  }
  if (authorization.substr(0, kBearer.size()) != kBearer) {
    return {AuthCode::kUnauthenticated, "authorization metadata is not 'Bearer <token>'"};
  }
  const std::string hash = Sha256Hex(authorization.substr(kBearer.size()));
  {
    std::lock_guard lock(mutex_);
    auto it = cache_.find(hash);
    if (it != cache_.end()) {
      *principal = it->second;
      return {};
    }
  }
  AuthStatus account_status;
  if (accounts_->Resolve(hash, principal, &account_status)) return account_status;
  auto found = store_->FindToken(hash);
  if (found.status.code == patient_db::StoreCode::kNotFound) {
    return {AuthCode::kUnauthenticated, "unknown token"};
  }
  if (!found.ok()) return {AuthCode::kInternal, found.status.message};
  Principal p{found.value.role, found.value.institution, found.value.trainee_id,
              TokenIdOf(hash), found.value.label};
  std::lock_guard lock(mutex_);
  cache_[hash] = p;
  *principal = p;
  return {};
}

AuthStatus RequireRole(const Principal& p, const std::vector<StoreRole>& roles,
                       const std::string& what) {
  for (StoreRole r : roles) {
    if (p.role == r) return {};
  }
  return Denied(std::string("role '") + patient_db::RoleName(p.role) + "' may not " + what);
}

AuthStatus RequireInstitution(const Principal& p, const std::string& institution,
                              const std::string& what) {
  if (p.role == StoreRole::kAdmin || p.institution == institution) return {};
  return Denied("institution '" + p.institution + "' may not " + what + " of institution '" +
                institution + "'");
}

AuthStatus RequireTraineeReader(const Principal& p, const patient_db::TraineeRow& trainee,
                                const std::string& what) {
  switch (p.role) {
    case StoreRole::kAdmin:
      return {};
    case StoreRole::kSupervisor:
      return RequireInstitution(p, trainee.institution, what);
    case StoreRole::kTrainee:
      if (p.trainee_id == trainee.trainee_id) return {};
      return Denied("a trainee may only " + what + " of their own records");
    case StoreRole::kStation:
      break;
  }
  return Denied("role 'station' may not " + what);
}

}  // namespace ves::server
