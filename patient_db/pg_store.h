#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include <pqxx/transaction>

#include "patient_db/pg_pool.h"
#include "patient_db/store.h"

// The Store on PostgreSQL (libpqxx), for deployments with several ves-server
// replicas on one database (docs/operations.md). Same schema and migrations as
// SQLite (PgMigrations()), applied under an advisory lock so replicas starting
// together agree. Every record commits with synchronous_commit=on.
//
// Retries (Transact): a transaction is re-run from the start only when that is
// known to be safe:
//  - serialization failure / deadlock: PostgreSQL rolled it back; re-run.
//  - connection lost before COMMIT was sent: nothing was committed; re-run
//    on a fresh connection.
//  - connection lost during COMMIT (pqxx::in_doubt_error): the outcome is
//    unknown, so it is looked up with txid_status() on a new connection:
//    committed -> success (nothing re-run), aborted -> re-run, still unknown ->
//    kInternal "outcome unknown" (the caller retries; session uploads are
//    keyed by UUID, so the retry is answered as a duplicate, never stored twice).
//  - anything else (constraint violations, bad SQL): no retry.
namespace ves::patient_db {

struct PgStoreOptions {
  std::string url;          // libpq URI, e.g. postgresql://ves@db.example/ves
  size_t pool_size = 8;     // connections per store (per server process)
  int max_attempts = 5;     // per transaction, for the retryable errors above
  int in_doubt_wait_ms = 10000;  // how long to wait for an in-doubt commit's fate
};

class PgStore final : public Store {
 public:
  // Connects and migrates. Throws std::runtime_error when it cannot.
  explicit PgStore(PgStoreOptions options);
  ~PgStore() override;

  // Every Store method (docs in store.h).
#include "patient_db/store_overrides.inc"

  int schema_version() const { return schema_version_; }

  // Counters for tests and logs.
  struct Stats {
    uint64_t retries = 0;           // transactions re-run
    uint64_t in_doubt_resolved = 0;  // in-doubt commits whose fate was looked up
  };
  Stats stats() const;

  // What Transact does with an error from a transaction that had not sent
  // COMMIT: true when re-running it is safe.
  static bool IsRetryableBeforeCommit(const std::exception& e);

 private:
  using Body = std::function<StoreStatus(pqxx::transaction_base&)>;
  enum class TxMode { kRead, kWrite };
  enum class InDoubt { kCommitted, kAborted, kUnknown };

  // Runs `body` in a transaction and commits it when it returns Ok (an error
  // status rolls back). Retries as described above.
  StoreStatus Transact(const std::string& what, TxMode mode, const Body& body);
  // A read (Transact, kRead) whose `body(tx)` returns its StoreResult<T>;
  // defined in pg_store_internal.h.
  template <typename T, typename Fn>
  StoreResult<T> Query(const std::string& what, const Fn& body);
  // Inserts a row a session has at most once (`sql` ends ON CONFLICT DO
  // NOTHING RETURNING 1): true when this one was stored, false when the
  // session already had one; kNotFound when there is no such session.
  template <typename... Args>
  StoreResult<bool> InsertOncePerSession(const std::string& what, const std::string& session_uuid,
                                         const std::string& sql, const Args&... args);
  InDoubt ResolveInDoubt(int64_t txid);
  void Migrate();
  StoreStatus ReadShares(pqxx::transaction_base& tx, CaseRow* row);

  PgStoreOptions options_;
  PgPool pool_;
  int schema_version_ = 0;
  mutable std::mutex stats_mutex_;
  Stats stats_;  // guarded by stats_mutex_
};

}  // namespace ves::patient_db
