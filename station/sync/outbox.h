#pragma once

#include <sqlite3.h>

#include <cstdint>
#include <filesystem>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "ves/v1/session.pb.h"

namespace ves::sync {

// One finished session waiting for the server's acknowledgement.
struct PendingUpload {
  std::string uuid;
  ves::v1::SessionRecord record;
  int attempts{0};
  std::string last_error;
};

// The station's durable outbox (DESIGN.md §6): a finished session is
// committed to a local SQLite database (WAL, synchronous=FULL) before any
// upload is tried, and stays there until the server acknowledges it. Keyed by
// the session's client UUID, so committing the same record twice stores it
// once, and a station killed at any moment loses nothing: on restart every
// unacknowledged record is pending again and is re-sent with the same UUID
// (the server's upload is idempotent on it). Durable means on disk, not only
// handed to the OS: with synchronous=FULL SQLite fsyncs the WAL before a
// commit returns, and the folder when it creates the database, journal and
// WAL (Outbox.ACommitIsOnDiskFileAndFolderBeforeItReturns watches both).
class Outbox {
 public:
  // Opens or creates the database; throws std::runtime_error naming the path.
  explicit Outbox(const std::filesystem::path& db_path);
  ~Outbox();
  Outbox(const Outbox&) = delete;
  Outbox& operator=(const Outbox&) = delete;

  // Durably stores the record (returns once it is on disk). A record whose
  // UUID is already stored with the same bytes is a no-op; with other bytes
  // it throws std::invalid_argument: a UUID names one session forever. So
  // does a record that would not read back (a string that is not UTF-8).
  void Commit(const ves::v1::SessionRecord& record);

  // Unacknowledged records, oldest first. A stored record that no longer
  // parses is set aside (as MarkRejected does, with the reason) instead of
  // failing the call: one bad record never blocks the others.
  std::vector<PendingUpload> Pending();
  std::size_t PendingCount() const;

  // Records set aside for good: refused by the server as invalid, or
  // unreadable. Kept, never retried, listed by `ves-station status`.
  struct SetAsideRecord {
    std::string uuid;
    int attempts{0};
    std::string reason;
  };
  std::vector<SetAsideRecord> SetAside() const;

  // Every stored session, pending, delivered or set aside: the station's
  // own history, which `ves-station status` lists. The newest `limit` by
  // commit, oldest first (a record carries its input log, megabytes for a
  // long session: status reads a bounded number). A record that no longer
  // parses is listed with readable false.
  struct StoredSession {
    std::string uuid;
    std::string state;  // "pending", "delivered" or "set aside"
    bool readable{true};
    ves::v1::SessionRecord record;
  };
  std::vector<StoredSession> Stored(std::size_t limit) const;
  std::size_t StoredCount() const;

  // The server acknowledged the record: it leaves the pending set (it is
  // kept, marked with the time, as the station's own history).
  void MarkAcknowledged(const std::string& uuid, int64_t acked_unix_ms);
  // An upload attempt failed; counted and its error kept for `status`.
  void RecordFailure(const std::string& uuid, const std::string& error);
  // The server refused the record for good (e.g. invalid): it stops being
  // retried but is never deleted, so nothing is lost.
  void MarkRejected(const std::string& uuid, const std::string& error);

  std::optional<ves::v1::SessionRecord> Find(const std::string& uuid) const;

 private:
  void Exec(const char* sql) const;

  std::filesystem::path path_;
  sqlite3* db_{nullptr};
  mutable std::mutex mutex_;
};

}  // namespace ves::sync
