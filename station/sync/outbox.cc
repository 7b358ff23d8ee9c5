#include "station/sync/outbox.h"

#include <google/protobuf/io/coded_stream.h>
#include <google/protobuf/io/zero_copy_stream_impl_lite.h>

#include <algorithm>
#include <stdexcept>

namespace ves::sync {
namespace {

// RAII statement with step/bind helpers; errors name the database and SQL.
class Statement {
 public:
  Statement(sqlite3* db, const char* sql, const std::filesystem::path& path) : db_(db) {
    if (sqlite3_prepare_v2(db, sql, -1, &stmt_, nullptr) != SQLITE_OK) {
      throw std::runtime_error("outbox " + path.string() + ": cannot prepare '" + sql +
                               "': " + sqlite3_errmsg(db));
    }
  }
  ~Statement() { sqlite3_finalize(stmt_); }
  Statement(const Statement&) = delete;
  Statement& operator=(const Statement&) = delete;

  void Bind(int index, const std::string& text) {
    sqlite3_bind_text(stmt_, index, text.data(), static_cast<int>(text.size()), SQLITE_TRANSIENT);
  }
  void BindBlob(int index, const std::string& bytes) {
    sqlite3_bind_blob(stmt_, index, bytes.data(), static_cast<int>(bytes.size()),
                      SQLITE_TRANSIENT);
  }
  void Bind(int index, int64_t value) { sqlite3_bind_int64(stmt_, index, value); }
  // Returns true while a row is available.
  bool Step() {
    const int rc = sqlite3_step(stmt_);
    if (rc == SQLITE_ROW) return true;
    if (rc == SQLITE_DONE) return false;
    throw std::runtime_error(std::string("outbox: ") + sqlite3_errmsg(db_));
  }
  std::string Text(int column) const {
    const auto* data = sqlite3_column_blob(stmt_, column);
    const int size = sqlite3_column_bytes(stmt_, column);
    return data ? std::string(static_cast<const char*>(data), size) : std::string();
  }
  int64_t Int(int column) const { return sqlite3_column_int64(stmt_, column); }

 private:
  sqlite3* db_;
  sqlite3_stmt* stmt_{nullptr};
};

std::string SerializeDeterministic(const ves::v1::SessionRecord& record) {
  std::string bytes;
  {
    google::protobuf::io::StringOutputStream stream(&bytes);
    google::protobuf::io::CodedOutputStream coded(&stream);
    coded.SetSerializationDeterministic(true);
    record.SerializeToCodedStream(&coded);
  }
  return bytes;
}

ves::v1::SessionRecord ParseRecord(const std::string& bytes, const std::string& uuid) {
  ves::v1::SessionRecord record;
  if (!record.ParseFromString(bytes)) {
    throw std::runtime_error("outbox: stored record " + uuid + " does not parse");
  }
  return record;
}

}  // namespace

Outbox::Outbox(const std::filesystem::path& db_path) : path_(db_path) {
  if (db_path.has_parent_path()) std::filesystem::create_directories(db_path.parent_path());
  if (sqlite3_open(db_path.c_str(), &db_) != SQLITE_OK) {
    const std::string message = db_ ? sqlite3_errmsg(db_) : "out of memory";
    sqlite3_close(db_);
    throw std::runtime_error("outbox: cannot open " + db_path.string() + ": " + message);
  }
  sqlite3_busy_timeout(db_, 5000);
  Exec("PRAGMA journal_mode=WAL");
  Exec("PRAGMA synchronous=FULL");
  Exec(
      "CREATE TABLE IF NOT EXISTS outbox ("
      " uuid TEXT PRIMARY KEY,"
      " record BLOB NOT NULL,"
      " committed_seq INTEGER NOT NULL,"
      " state TEXT NOT NULL DEFAULT 'pending',"  // pending | acked | rejected
      " attempts INTEGER NOT NULL DEFAULT 0,"
      " last_error TEXT NOT NULL DEFAULT '',"
      " acked_unix_ms INTEGER)");
}

Outbox::~Outbox() { sqlite3_close(db_); }

void Outbox::Exec(const char* sql) const {
  char* error = nullptr;
  if (sqlite3_exec(db_, sql, nullptr, nullptr, &error) != SQLITE_OK) {
    const std::string message = error ? error : "unknown error";
    sqlite3_free(error);
    throw std::runtime_error("outbox " + path_.string() + ": '" + sql + "' failed: " + message);
  }
}

void Outbox::Commit(const ves::v1::SessionRecord& record) {
  if (record.uuid().empty()) throw std::invalid_argument("outbox: session record has no uuid");
  const std::string bytes = SerializeDeterministic(record);
  // Protobuf writes a string that is not UTF-8 but will not read it back:
  // such a record would sit in the outbox unreadable forever.
  if (ves::v1::SessionRecord readable; !readable.ParseFromString(bytes)) {
    throw std::invalid_argument("outbox: session " + record.uuid() +
                                " would not read back (a string field that is not UTF-8?)");
  }
  std::lock_guard lock(mutex_);
  Exec("BEGIN IMMEDIATE");
  try {
    Statement find(db_, "SELECT record FROM outbox WHERE uuid = ?", path_);
    find.Bind(1, record.uuid());
    if (find.Step()) {
      if (find.Text(0) != bytes) {
        throw std::invalid_argument("outbox: session " + record.uuid() +
                                    " is already stored with different content");
      }
    } else {
      Statement insert(db_,
                       "INSERT INTO outbox (uuid, record, committed_seq) VALUES "
                       "(?, ?, (SELECT COALESCE(MAX(committed_seq), 0) + 1 FROM outbox))",
                       path_);
      insert.Bind(1, record.uuid());
      insert.BindBlob(2, bytes);
      insert.Step();
    }
    Exec("COMMIT");
  } catch (...) {
    Exec("ROLLBACK");
    throw;
  }
}

std::vector<PendingUpload> Outbox::Pending() {
  std::lock_guard lock(mutex_);
  std::vector<PendingUpload> pending;
  std::vector<std::string> unreadable;
  {
    Statement select(db_,
                     "SELECT uuid, record, attempts, last_error FROM outbox "
                     "WHERE state = 'pending' ORDER BY committed_seq",
                     path_);
    while (select.Step()) {
      PendingUpload upload;
      upload.uuid = select.Text(0);
      if (!upload.record.ParseFromString(select.Text(1))) {
        unreadable.push_back(upload.uuid);
        continue;
      }
      upload.attempts = static_cast<int>(select.Int(2));
      upload.last_error = select.Text(3);
      pending.push_back(std::move(upload));
    }
  }
  for (const std::string& uuid : unreadable) {
    Statement update(db_,
                     "UPDATE outbox SET state = 'rejected', last_error = ? WHERE uuid = ?",
                     path_);
    update.Bind(1, std::string("set aside: the stored record does not parse"));
    update.Bind(2, uuid);
    update.Step();
  }
  return pending;
}

std::vector<Outbox::SetAsideRecord> Outbox::SetAside() const {
  std::lock_guard lock(mutex_);
  Statement select(db_,
                   "SELECT uuid, attempts, last_error FROM outbox WHERE state = 'rejected' "
                   "ORDER BY committed_seq",
                   path_);
  std::vector<SetAsideRecord> out;
  while (select.Step()) {
    out.push_back({select.Text(0), static_cast<int>(select.Int(1)), select.Text(2)});
  }
  return out;
}

std::vector<Outbox::StoredSession> Outbox::Stored(std::size_t limit) const {
  std::lock_guard lock(mutex_);
  Statement select(db_,
                   "SELECT uuid, record, state FROM outbox ORDER BY committed_seq DESC LIMIT ?",
                   path_);
  select.Bind(1, static_cast<int64_t>(limit));
  std::vector<StoredSession> out;
  while (select.Step()) {
    StoredSession stored;
    stored.uuid = select.Text(0);
    stored.readable = stored.record.ParseFromString(select.Text(1));
    const std::string state = select.Text(2);
    stored.state = state == "acked" ? "delivered" : state == "rejected" ? "set aside" : "pending";
    out.push_back(std::move(stored));
  }
  std::reverse(out.begin(), out.end());
  return out;
}

std::size_t Outbox::StoredCount() const {
  std::lock_guard lock(mutex_);
  Statement count(db_, "SELECT COUNT(*) FROM outbox", path_);
  count.Step();
  return static_cast<std::size_t>(count.Int(0));
}

std::size_t Outbox::PendingCount() const {
  std::lock_guard lock(mutex_);
  Statement count(db_, "SELECT COUNT(*) FROM outbox WHERE state = 'pending'", path_);
  count.Step();
  return static_cast<std::size_t>(count.Int(0));
}

void Outbox::MarkAcknowledged(const std::string& uuid, int64_t acked_unix_ms) {
  std::lock_guard lock(mutex_);
  Statement update(db_, "UPDATE outbox SET state = 'acked', acked_unix_ms = ? WHERE uuid = ?",
                   path_);
  update.Bind(1, acked_unix_ms);
  update.Bind(2, uuid);
  update.Step();
}

void Outbox::RecordFailure(const std::string& uuid, const std::string& error) {
  std::lock_guard lock(mutex_);
  Statement update(db_,
                   "UPDATE outbox SET attempts = attempts + 1, last_error = ? WHERE uuid = ?",
                   path_);
  update.Bind(1, error);
  update.Bind(2, uuid);
  update.Step();
}

void Outbox::MarkRejected(const std::string& uuid, const std::string& error) {
  std::lock_guard lock(mutex_);
  Statement update(db_,
                   "UPDATE outbox SET state = 'rejected', attempts = attempts + 1, "
                   "last_error = ? WHERE uuid = ?",
                   path_);
  update.Bind(1, error);
  update.Bind(2, uuid);
  update.Step();
}

std::optional<ves::v1::SessionRecord> Outbox::Find(const std::string& uuid) const {
  std::lock_guard lock(mutex_);
  Statement select(db_, "SELECT record FROM outbox WHERE uuid = ?", path_);
  select.Bind(1, uuid);
  if (!select.Step()) return std::nullopt;
  return ParseRecord(select.Text(0), uuid);
}

}  // namespace ves::sync
