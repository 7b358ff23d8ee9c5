// PgStore: accounts of people who sign in to the web pages
// (docs/web.md, "Accounts"). Schema: migration 8, the same SQL as SQLite.
#include <pqxx/pqxx>

#include "patient_db/pg_store.h"
#include "patient_db/pg_store_internal.h"
#include "patient_db/store_rows.h"

namespace ves::patient_db {
namespace {

StoreResult<AccountRow> ReadOne(pqxx::transaction_base& tx, const char* column,
                                const std::string& value) {
  pqxx::result r = tx.exec_params(std::string("SELECT ") + kAccountColumns +
                                      " FROM accounts WHERE " + column + " = $1",
                                  value);
  if (r.empty()) return StoreStatus::Error(StoreCode::kNotFound, "no such account");
  return AccountRowFrom(PgColumns(r[0]));
}

}  // namespace

StoreStatus PgStore::AddAccount(const AccountRow& a) {
  return Transact("add account", TxMode::kWrite, [&](pqxx::transaction_base& tx) {
    // Both unique keys are checked in the statement: a clash answers
    // kAlreadyExists naming the key rather than a constraint error.
    pqxx::result taken = tx.exec_params(
        "SELECT username, idp_identity FROM accounts WHERE username = $1 OR "
        "($2 <> '' AND idp_identity = $2)",
        a.username, a.idp_identity);
    if (!taken.empty()) {
      const bool by_name = taken[0][0].as<std::string>() == a.username;
      return StoreStatus::Error(StoreCode::kAlreadyExists,
                                std::string("an account with ") +
                                    (by_name ? "username '" + a.username
                                             : "idp_identity '" + a.idp_identity) +
                                    "' already exists");
    }
    tx.exec_params(std::string("INSERT INTO accounts (") + kAccountColumns +
                       ") VALUES ($1, $2, $3, $4, $5, $6, $7, $8)",
                   a.username, std::string(RoleName(a.role)), a.institution, a.password_hash,
                   a.idp_identity, a.created_unix_ms, a.expires_unix_ms, a.revoked_unix_ms);
    return StoreStatus::Ok();
  });
}

StoreResult<AccountRow> PgStore::GetAccount(const std::string& username) {
  return Query<AccountRow>(
      "get account", [&](pqxx::transaction_base& tx) { return ReadOne(tx, "username", username); });
}

StoreResult<AccountRow> PgStore::FindAccountByIdentity(const std::string& identity) {
  if (identity.empty()) return StoreStatus::Error(StoreCode::kNotFound, "no such account");
  return Query<AccountRow>("find account", [&](pqxx::transaction_base& tx) {
    return ReadOne(tx, "idp_identity", identity);
  });
}

StoreResult<std::vector<AccountRow>> PgStore::ListAccounts(const std::string& institution) {
  return Query<std::vector<AccountRow>>("list accounts", [&](pqxx::transaction_base& tx) {
    return RowsOf(tx.exec_params(std::string("SELECT ") + kAccountColumns +
                                     " FROM accounts WHERE $1 = '' OR institution = $1 "
                                     "ORDER BY username",
                                 institution),
                  AccountRowFrom<PgColumns>);
  });
}

StoreStatus PgStore::RevokeAccount(const std::string& username, int64_t now_unix_ms) {
  return Transact("revoke account", TxMode::kWrite, [&](pqxx::transaction_base& tx) {
    pqxx::result r = tx.exec_params(
        "UPDATE accounts SET revoked_unix_ms = CASE WHEN revoked_unix_ms = 0 THEN $1 "
        "ELSE revoked_unix_ms END WHERE username = $2 RETURNING 1",
        now_unix_ms, username);
    if (r.empty()) return StoreStatus::Error(StoreCode::kNotFound, "no account '" + username + "'");
    return StoreStatus::Ok();
  });
}

StoreStatus PgStore::SetAccountPassword(const std::string& username,
                                        const std::string& password_hash) {
  return Transact("set account password", TxMode::kWrite, [&](pqxx::transaction_base& tx) {
    pqxx::result r = tx.exec_params(
        "UPDATE accounts SET password_hash = $1 WHERE username = $2 RETURNING 1", password_hash,
        username);
    if (r.empty()) return StoreStatus::Error(StoreCode::kNotFound, "no account '" + username + "'");
    return StoreStatus::Ok();
  });
}

}  // namespace ves::patient_db
