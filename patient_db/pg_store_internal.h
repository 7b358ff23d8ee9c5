#pragma once

#include <cstdint>
#include <pqxx/pqxx>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "patient_db/pg_store.h"

// Helpers of the PgStore's source files (pg_store*.cc); not for other code.
namespace ves::patient_db {

// A result row read as store_rows.h reads columns (BYTEA for Blob).
class PgColumns {
 public:
  explicit PgColumns(const pqxx::row& row) : row_(row) {}
  std::string Text(int i) const { return row_[i].as<std::string>(); }
  int64_t Int(int i) const { return row_[i].as<int64_t>(); }
  double Real(int i) const { return row_[i].as<double>(); }
  std::string Blob(int i) const { return pqxx::binarystring(row_[i]).str(); }

 private:
  const pqxx::row& row_;
};

// The rows of `r`, each as `read(PgColumns(row))` makes it.
template <typename Read>
auto RowsOf(const pqxx::result& r, Read read) {
  std::vector<std::decay_t<decltype(read(std::declval<const PgColumns&>()))>> out;
  for (const auto& row : r) out.push_back(read(PgColumns(row)));
  return out;
}

template <typename T, typename Fn>
StoreResult<T> PgStore::Query(const std::string& what, const Fn& body) {
  StoreResult<T> out;
  StoreStatus st = Transact(what, TxMode::kRead, [&](pqxx::transaction_base& tx) {
    out = body(tx);
    return out.status;
  });
  if (!st.ok()) return st;
  return out;
}

template <typename... Args>
StoreResult<bool> PgStore::InsertOncePerSession(const std::string& what,
                                                const std::string& session_uuid,
                                                const std::string& sql, const Args&... args) {
  bool inserted = false;
  StoreStatus st = Transact(what, TxMode::kWrite, [&](pqxx::transaction_base& tx) {
    inserted = !tx.exec_params(sql, args...).empty();
    return StoreStatus::Ok();
  });
  // A foreign key violation: the session is not stored.
  if (st.code == StoreCode::kInvalidArgument) {
    return StoreStatus::Error(StoreCode::kNotFound, "no session '" + session_uuid + "'");
  }
  if (!st.ok()) return st;
  return inserted;
}

}  // namespace ves::patient_db
