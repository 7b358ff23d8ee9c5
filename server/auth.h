#pragma once

#include <memory>
#include <mutex>
#include <string>
#include <string_view>
#include <unordered_map>
#include <vector>

#include "patient_db/case_bundle.h"
#include "patient_db/store.h"

// Bearer tokens and the access rules of docs/server.md. Tokens are 256 random
// bits (64 hex digits); the store keeps only their SHA-256. Nothing here knows
// gRPC: handlers map AuthStatus to grpc::Status.
namespace ves::server {

using patient_db::StoreRole;
class Accounts;

struct Principal {
  StoreRole role = StoreRole::kTrainee;
  std::string institution;
  std::string trainee_id;  // trainee role only
  std::string token_id;    // first 12 hex digits of the token hash
  std::string label;
};

enum class AuthCode { kOk, kUnauthenticated, kPermissionDenied, kInternal };

struct AuthStatus {
  AuthCode code = AuthCode::kOk;
  std::string message;
  bool ok() const { return code == AuthCode::kOk; }
};

// A new random token (OpenSSL RAND_bytes); throws std::runtime_error if the
// generator fails.
std::string NewToken();
// SHA-256 as lower-case hex: the one implementation is the case bundles'
// (patient_db/case_bundle.h); tokens are stored by it.
using patient_db::Sha256Hex;
std::string TokenIdOf(const std::string& token_sha256_hex);

// Resolves `authorization` metadata ("Bearer <token>") to a principal. Hashes
// are cached: tokens are never changed once stored. A browser signed in with
// an account (server/accounts.h) carries a session secret instead, which is
// resolved against the account on every call, never cached.
class Authenticator {
 public:
  explicit Authenticator(patient_db::Store* store);
  ~Authenticator();
  AuthStatus Authenticate(std::string_view authorization, Principal* principal);
  Accounts& accounts() { return *accounts_; }

 private:
  patient_db::Store* store_;
  std::unique_ptr<Accounts> accounts_;
  std::mutex mutex_;
  std::unordered_map<std::string, Principal> cache_;  // by token hash
};

// kPermissionDenied unless the principal has one of `roles` (`what` names the call).
AuthStatus RequireRole(const Principal& p, const std::vector<StoreRole>& roles,
                       const std::string& what);
// Admins reach every institution; everyone else only their own.
AuthStatus RequireInstitution(const Principal& p, const std::string& institution,
                              const std::string& what);
// Reading a trainee's records: admin; supervisor of the trainee's institution;
// the trainee themself.
AuthStatus RequireTraineeReader(const Principal& p, const patient_db::TraineeRow& trainee,
                                const std::string& what);

}  // namespace ves::server
