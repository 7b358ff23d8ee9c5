#pragma once

#include <cstdint>
#include <string>

#include <pqxx/row>

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

}  // namespace ves::patient_db
