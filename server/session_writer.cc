#include "server/session_writer.h"

#include <algorithm>

namespace ves::server {

using patient_db::SessionPut;

SessionWriter::SessionWriter(patient_db::Store* store, size_t max_batch)
    : store_(store), max_batch_(max_batch), thread_([this] { Loop(); }) {}

SessionWriter::~SessionWriter() { Stop(); }

void SessionWriter::Submit(patient_db::SessionRow row, patient_db::AuditRow audit, Done done) {
  {
    std::lock_guard lock(mutex_);
    pending_.push_back({std::move(row), std::move(audit), std::move(done)});
  }
  wake_.notify_one();
}

void SessionWriter::SubmitAudit(patient_db::AuditRow audit) {
  {
    std::lock_guard lock(mutex_);
    pending_audit_.push_back(std::move(audit));
  }
  wake_.notify_one();
}

void SessionWriter::Stop() {
  {
    std::lock_guard lock(mutex_);
    if (stopping_ && !thread_.joinable()) return;
    stopping_ = true;
  }
  wake_.notify_one();
  if (thread_.joinable()) thread_.join();
}

uint64_t SessionWriter::batches() const {
  std::lock_guard lock(mutex_);
  return batches_;
}

void SessionWriter::Loop() {
  std::vector<Pending> work;
  for (;;) {
    patient_db::WriteBatch batch;
    {
      std::unique_lock lock(mutex_);
      wake_.wait(lock, [&] { return stopping_ || !pending_.empty() || !pending_audit_.empty(); });
      if (pending_.empty() && pending_audit_.empty()) return;  // stopping and drained
      // Everything that arrived while the last commit was syncing forms this batch.
      const size_t n = std::min(pending_.size(), max_batch_);
      work.assign(std::make_move_iterator(pending_.begin()),
                  std::make_move_iterator(pending_.begin() + n));
      pending_.erase(pending_.begin(), pending_.begin() + n);
      batch.audit.swap(pending_audit_);
    }
    for (Pending& p : work) {
      batch.sessions.push_back(std::move(p.row));
      batch.session_audit.push_back(std::move(p.audit));
    }
    auto result = store_->CommitBatch(batch);
    {
      std::lock_guard lock(mutex_);
      ++batches_;
    }
    for (size_t i = 0; i < work.size(); ++i) {
      work[i].done(result.status,
                   result.ok() ? result.value[i] : patient_db::SessionPutResult{});
    }
    work.clear();
  }
}

}  // namespace ves::server
