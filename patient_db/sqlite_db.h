#pragma once

#include <sqlite3.h>

#include <cstdint>
#include <memory>
#include <string>
#include <string_view>
#include <unordered_map>

// A thin RAII layer over one SQLite connection: open with the server's
// settings (WAL, synchronous=FULL, foreign keys), cached prepared statements
// and typed binding. Not thread-safe: one connection per thread at a time.
namespace ves::patient_db {

class SqliteStatement;

class SqliteDb {
 public:
  // Throws std::runtime_error naming the path and SQLite's message.
  explicit SqliteDb(const std::string& path);
  ~SqliteDb();
  SqliteDb(const SqliteDb&) = delete;
  SqliteDb& operator=(const SqliteDb&) = delete;

  // Runs SQL without results (may hold several statements); false on error.
  bool Exec(const std::string& sql, std::string* error);
  // A cached prepared statement, reset and unbound; nullptr on error.
  SqliteStatement* Prepare(const std::string& sql, std::string* error);
  std::string LastError() const;
  sqlite3* raw() { return db_; }

 private:
  sqlite3* db_ = nullptr;
  std::unordered_map<std::string, std::unique_ptr<SqliteStatement>> cache_;
};

class SqliteStatement {
 public:
  explicit SqliteStatement(sqlite3_stmt* stmt) : stmt_(stmt) {}
  ~SqliteStatement() { sqlite3_finalize(stmt_); }
  SqliteStatement(const SqliteStatement&) = delete;
  SqliteStatement& operator=(const SqliteStatement&) = delete;

  // Binding is 1-based, as in SQL's ?NNN.
  SqliteStatement& Bind(int i, int64_t v);
  SqliteStatement& Bind(int i, double v);
  SqliteStatement& Bind(int i, std::string_view text);
  SqliteStatement& BindBlob(int i, std::string_view bytes);
  // SQLITE_ROW → true, SQLITE_DONE → false; any other code sets *rc.
  bool Step(int* rc);
  void Reset();

  int64_t Int(int col) const { return sqlite3_column_int64(stmt_, col); }
  double Real(int col) const { return sqlite3_column_double(stmt_, col); }
  std::string Text(int col) const;
  std::string Blob(int col) const;

 private:
  sqlite3_stmt* stmt_;
};

}  // namespace ves::patient_db
