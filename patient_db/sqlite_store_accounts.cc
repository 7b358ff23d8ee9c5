// SqliteStore: accounts of people who sign in to the web pages
// (docs/web.md, "Accounts"). Schema: migration 8.
#include <optional>

#include "patient_db/sqlite_store.h"
#include "patient_db/sqlite_store_internal.h"
#include "patient_db/store_rows.h"

namespace ves::patient_db {
namespace {

// One account by `column` (username or idp_identity).
StoreResult<AccountRow> ReadOne(SqliteDb& db, const char* column, const std::string& value) {
  return ReadFirst(
      db, "get account", "no such account",
      std::string("SELECT ") + kAccountColumns + " FROM accounts WHERE " + column + " = ?",
      AccountRowFrom<SqliteStatement>, value);
}

// An UPDATE of one account by username: kNotFound when no row changed.
template <typename Value>
StoreStatus UpdateOne(SqliteDb& db, const char* sql, const Value& value,
                      const std::string& username, const std::string& what) {
  int rc = SQLITE_OK;
  if (!Execute(db, sql, &rc, value, username)) return Internal(db, what);
  if (sqlite3_changes(db.raw()) == 0) {
    return StoreStatus::Error(StoreCode::kNotFound, "no account '" + username + "'");
  }
  return StoreStatus::Ok();
}

}  // namespace

StoreStatus SqliteStore::AddAccount(const AccountRow& a) {
  std::lock_guard lock(write_mutex_);
  SqliteDb& db = *writer_;
  for (const auto& [column, value] : {std::pair<const char*, std::string>{"username", a.username},
                                      {"idp_identity", a.idp_identity}}) {
    if (value.empty()) continue;
    auto found = ReadOne(db, column, value);
    if (found.ok()) {
      return StoreStatus::Error(StoreCode::kAlreadyExists, std::string("an account with ") +
                                                               column + " '" + value +
                                                               "' already exists");
    }
    if (found.status.code != StoreCode::kNotFound) return found.status;
  }
  int rc = SQLITE_OK;
  if (Execute(db,
              std::string("INSERT INTO accounts (") + kAccountColumns +
                  ") VALUES (?, ?, ?, ?, ?, ?, ?, ?)",
              &rc, a.username, RoleName(a.role), a.institution, a.password_hash, a.idp_identity,
              a.created_unix_ms, a.expires_unix_ms, a.revoked_unix_ms)) {
    return StoreStatus::Ok();
  }
  if (IsConstraint(rc)) {
    return StoreStatus::Error(StoreCode::kInvalidArgument, "add account: " + db.LastError());
  }
  return Internal(db, "add account");
}

StoreResult<AccountRow> SqliteStore::GetAccount(const std::string& username) {
  Reader r = Read();
  return ReadOne(r.db(), "username", username);
}

StoreResult<AccountRow> SqliteStore::FindAccountByIdentity(const std::string& identity) {
  if (identity.empty()) return StoreStatus::Error(StoreCode::kNotFound, "no such account");
  Reader r = Read();
  return ReadOne(r.db(), "idp_identity", identity);
}

StoreResult<std::vector<AccountRow>> SqliteStore::ListAccounts(const std::string& institution) {
  Reader r = Read();
  return ReadRows(r.db(), "list accounts",
                  std::string("SELECT ") + kAccountColumns +
                      " FROM accounts WHERE ? = '' OR institution = ? ORDER BY username",
                  AccountRowFrom<SqliteStatement>, institution, institution);
}

StoreStatus SqliteStore::RevokeAccount(const std::string& username, int64_t now_unix_ms) {
  std::lock_guard lock(write_mutex_);
  return UpdateOne(*writer_,
                   "UPDATE accounts SET revoked_unix_ms = CASE WHEN revoked_unix_ms = 0 THEN ? "
                   "ELSE revoked_unix_ms END WHERE username = ?",
                   now_unix_ms, username, "revoke account");
}

StoreStatus SqliteStore::SetAccountPassword(const std::string& username,
                                            const std::string& password_hash) {
  std::lock_guard lock(write_mutex_);
  return UpdateOne(*writer_, "UPDATE accounts SET password_hash = ? WHERE username = ?",
                   password_hash, username, "set account password");
}

}  // namespace ves::patient_db
