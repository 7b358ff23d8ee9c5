#pragma once

#include <condition_variable>
#include <cstdint>
#include <functional>
#include <mutex>
#include <thread>
#include <vector>

#include "patient_db/store.h"

// Group commit (docs/server.md, "Durability"): one writer thread takes every
// pending session upload and audit row and writes them in one durable
// transaction, then acknowledges each upload. With synchronous=FULL a commit
// costs one WAL fsync whatever the batch size, so throughput grows with the
// number of concurrent clients instead of being capped at one fsync per record.
namespace ves::server {

class SessionWriter {
 public:
  using Done = std::function<void(const patient_db::StoreStatus&,
                                  const patient_db::SessionPutResult&)>;

  explicit SessionWriter(patient_db::Store* store, size_t max_batch = 512);
  ~SessionWriter();  // drains and joins
  SessionWriter(const SessionWriter&) = delete;
  SessionWriter& operator=(const SessionWriter&) = delete;

  // `done` runs on the writer thread once the row's transaction committed (or
  // failed). `audit` is written in the same transaction, its result filled in
  // from the outcome.
  void Submit(patient_db::SessionRow row, patient_db::AuditRow audit, Done done);
  // Written with the next batch; nobody waits for it.
  void SubmitAudit(patient_db::AuditRow audit);
  // Writes what is pending, then stops the thread. Idempotent.
  void Stop();

  uint64_t batches() const;  // commits so far, for the log and tests

 private:
  struct Pending {
    patient_db::SessionRow row;
    patient_db::AuditRow audit;
    Done done;
  };
  void Loop();

  patient_db::Store* store_;
  const size_t max_batch_;
  mutable std::mutex mutex_;
  std::condition_variable wake_;
  std::vector<Pending> pending_;
  std::vector<patient_db::AuditRow> pending_audit_;
  bool stopping_ = false;
  uint64_t batches_ = 0;
  std::thread thread_;
};

}  // namespace ves::server
