#pragma once

#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "patient_db/sqlite_db.h"
#include "patient_db/store.h"

// The embedded Store: one SQLite file in WAL mode, synchronous=FULL, foreign
// keys on. Writes go through one connection under a mutex (SQLite has one
// writer anyway); reads take a connection from a small pool so they run beside
// a commit. Migrations are applied when it opens.
namespace ves::patient_db {

class SqliteStore final : public Store {
 public:
  // Throws std::runtime_error when the file cannot be opened or migrated.
  explicit SqliteStore(const std::string& path);
  ~SqliteStore() override;

  // Every Store method (docs in store.h).
#include "patient_db/store_overrides.inc"

  // The schema version after migration.
  int schema_version() const { return schema_version_; }

 private:
  // A pooled read connection, returned on destruction.
  class Reader;
  Reader Read();
  void Migrate();
  // Writes the blob (once) and the case row of a new case version.
  StoreStatus WriteCase(const CaseRow& row, const std::string& payload);
  StoreStatus WriteSession(const SessionRow& row, SessionPutResult* result);
  StoreStatus WriteAudit(const AuditRow& row);
  StoreStatus WriteStation(const StationRow& report);
  StoreResult<CurriculumRow> ReadCurriculum(SqliteDb& db, const std::string& curriculum_id);
  StoreResult<std::vector<std::string>> ReadShares(SqliteDb& db, const std::string& case_id,
                                                   uint32_t version);

  std::string path_;
  std::mutex write_mutex_;
  std::unique_ptr<SqliteDb> writer_;  // guarded by write_mutex_
  int64_t next_audit_id_ = 1;         // guarded by write_mutex_
  std::mutex pool_mutex_;
  std::vector<std::unique_ptr<SqliteDb>> readers_;  // idle; guarded by pool_mutex_
  int schema_version_ = 0;
};

// A pooled read connection, handed back to the pool when it goes out of scope.
class SqliteStore::Reader {
 public:
  Reader(SqliteStore* store, std::unique_ptr<SqliteDb> db) : store_(store), db_(std::move(db)) {}
  ~Reader() {
    std::lock_guard lock(store_->pool_mutex_);
    store_->readers_.push_back(std::move(db_));
  }
  Reader(const Reader&) = delete;
  Reader& operator=(const Reader&) = delete;
  SqliteDb& db() { return *db_; }

 private:
  SqliteStore* store_;
  std::unique_ptr<SqliteDb> db_;
};

}  // namespace ves::patient_db
