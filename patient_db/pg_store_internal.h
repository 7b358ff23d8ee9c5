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

// A result row read as store_rows.h reads columns.
class PgColumns {
 public:
  explicit PgColumns(const pqxx::row& row) : row_(row) {}
  std::string Text(int i) const { return row_[i].as<std::string>(); }
  int64_t Int(int i) const { return row_[i].as<int64_t>(); }
  double Real(int i) const { return row_[i].as<double>(); }

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

}  // namespace ves::patient_db
