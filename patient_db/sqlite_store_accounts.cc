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
  SqliteStatement* s = db.Prepare(std::string("SELECT ") + kAccountColumns +
                                      " FROM accounts WHERE " + column + " = ?",
                                  nullptr);
  if (!s) return Internal(db, "get account");
  s->Bind(1, value);
  int rc = SQLITE_OK;
  std::optional<AccountRow> row;
  if (s->Step(&rc)) row = AccountRowFrom(*s);
  s->Reset();
  if (rc != SQLITE_OK) return Internal(db, "get account");
  if (!row) return StoreStatus::Error(StoreCode::kNotFound, "no such account");
  return std::move(*row);
}

// An UPDATE of one account by username: kNotFound when no row changed.
template <typename Value>
StoreStatus UpdateOne(SqliteDb& db, const char* sql, const Value& value,
                      const std::string& username, const std::string& what) {
  SqliteStatement* s = db.Prepare(sql, nullptr);
  if (!s) return Internal(db, what);
  s->Bind(1, value).Bind(2, username);
  int rc = SQLITE_OK;
  s->Step(&rc);
  s->Reset();
  if (rc != SQLITE_OK) return Internal(db, what);
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
  SqliteStatement* s = db.Prepare(std::string("INSERT INTO accounts (") + kAccountColumns +
                                      ") VALUES (?, ?, ?, ?, ?, ?, ?, ?)",
                                  nullptr);
  if (!s) return Internal(db, "add account");
  s->Bind(1, a.username).Bind(2, RoleName(a.role)).Bind(3, a.institution);
  s->Bind(4, a.password_hash).Bind(5, a.idp_identity).Bind(6, a.created_unix_ms);
  s->Bind(7, a.expires_unix_ms).Bind(8, a.revoked_unix_ms);
  int rc = SQLITE_OK;
  s->Step(&rc);
  s->Reset();
  if (rc == SQLITE_OK) return StoreStatus::Ok();
  if ((rc & 0xff) == SQLITE_CONSTRAINT) {
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
  SqliteStatement* s = r.db().Prepare(std::string("SELECT ") + kAccountColumns +
                                          " FROM accounts WHERE ? = '' OR institution = ? "
                                          "ORDER BY username",
                                      nullptr);
  if (!s) return Internal(r.db(), "list accounts");
  s->Bind(1, institution).Bind(2, institution);
  int rc = SQLITE_OK;
  std::vector<AccountRow> out;
  while (s->Step(&rc)) out.push_back(AccountRowFrom(*s));
  s->Reset();
  if (rc != SQLITE_OK) return Internal(r.db(), "list accounts");
  return out;
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
