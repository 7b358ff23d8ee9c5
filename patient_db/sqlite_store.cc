#include "patient_db/sqlite_store.h"

#include <stdexcept>

#include "patient_db/clock.h"
#include "patient_db/migrations/migrations.h"
#include "patient_db/sqlite_store_internal.h"
#include "patient_db/store_rows.h"

namespace ves::patient_db {
namespace {

// A constraint failure is the caller's mistake (unknown institution, ...).
StoreStatus FromStep(SqliteDb& db, int rc, const std::string& what) {
  if ((rc & 0xff) == SQLITE_CONSTRAINT) {
    return StoreStatus::Error(StoreCode::kInvalidArgument, what + ": " + db.LastError());
  }
  return Internal(db, what);
}

}  // namespace

SqliteStore::SqliteStore(const std::string& path) : path_(path) {
  writer_ = std::make_unique<SqliteDb>(path);
  Migrate();
  std::string error;
  SqliteStatement* s = writer_->Prepare("SELECT COALESCE(MAX(id), 0) FROM audit_log", &error);
  if (!s) throw std::runtime_error("cannot read audit log of '" + path + "': " + error);
  int rc = SQLITE_OK;
  if (s->Step(&rc)) next_audit_id_ = s->Int(0) + 1;
  s->Reset();
}

SqliteStore::~SqliteStore() = default;

SqliteStore::Reader SqliteStore::Read() {
  std::unique_ptr<SqliteDb> db;
  {
    std::lock_guard lock(pool_mutex_);
    if (!readers_.empty()) {
      db = std::move(readers_.back());
      readers_.pop_back();
    }
  }
  if (!db) db = std::make_unique<SqliteDb>(path_);
  return Reader(this, std::move(db));
}

void SqliteStore::Migrate() {
  std::string error;
  auto fail = [&](const std::string& what) {
    throw std::runtime_error("migration of '" + path_ + "' failed: " + what + ": " + error);
  };
  if (!writer_->Exec("CREATE TABLE IF NOT EXISTS schema_migrations (version INTEGER PRIMARY KEY, "
                     "description TEXT NOT NULL, applied_unix_ms BIGINT NOT NULL)",
                     &error)) {
    fail("schema_migrations");
  }
  for (const Migration& m : SqlMigrations()) {
    if (!writer_->Exec("BEGIN IMMEDIATE", &error)) fail("begin");
    // Checked inside the transaction so two processes starting together agree.
    SqliteStatement* s =
        writer_->Prepare("SELECT COUNT(*) FROM schema_migrations WHERE version = ?", &error);
    if (!s) fail("version query");
    s->Bind(1, int64_t{m.version});
    int rc = SQLITE_OK;
    const bool applied = s->Step(&rc) && s->Int(0) > 0;
    s->Reset();
    if (!applied) {
      if (!writer_->Exec(m.sql, &error)) {
        writer_->Exec("ROLLBACK", nullptr);
        fail("version " + std::to_string(m.version));
      }
      SqliteStatement* ins = writer_->Prepare(
          "INSERT INTO schema_migrations (version, description, applied_unix_ms) VALUES (?, ?, ?)",
          &error);
      if (!ins) fail("record");
      ins->Bind(1, int64_t{m.version}).Bind(2, m.description).Bind(3, NowUnixMs());
      rc = SQLITE_OK;
      ins->Step(&rc);
      ins->Reset();
      if (rc != SQLITE_OK) {
        error = writer_->LastError();
        writer_->Exec("ROLLBACK", nullptr);
        fail("record");
      }
    }
    if (!writer_->Exec("COMMIT", &error)) fail("commit");
    schema_version_ = m.version;
  }
}

StoreStatus SqliteStore::AddInstitution(const std::string& name, int64_t now_unix_ms) {
  std::lock_guard lock(write_mutex_);
  int rc = SQLITE_OK;
  if (Execute(*writer_,
              "INSERT INTO institutions (name, created_unix_ms) VALUES (?, ?) "
              "ON CONFLICT (name) DO NOTHING",
              &rc, name, now_unix_ms)) {
    return StoreStatus::Ok();
  }
  return FromStep(*writer_, rc, "add institution");
}

StoreResult<bool> SqliteStore::HasInstitution(const std::string& name) {
  Reader r = Read();
  bool found = false;
  StoreStatus st = ForEachRow(
      r.db(), "find institution", "SELECT 1 FROM institutions WHERE name = ?",
      [&](const SqliteStatement&) {
        found = true;
        return false;
      },
      name);
  if (!st.ok()) return st;
  return found;
}

StoreStatus SqliteStore::AddToken(const TokenRow& t) {
  std::lock_guard lock(write_mutex_);
  int rc = SQLITE_OK;
  if (Execute(*writer_,
              "INSERT INTO tokens (token_sha256_hex, role, institution, trainee_id, label, "
              "created_unix_ms) VALUES (?, ?, ?, ?, ?, ?)",
              &rc, t.token_sha256_hex, RoleName(t.role), t.institution, t.trainee_id, t.label,
              t.created_unix_ms)) {
    return StoreStatus::Ok();
  }
  return FromStep(*writer_, rc, "add token");
}

StoreResult<TokenRow> SqliteStore::FindToken(const std::string& token_sha256_hex) {
  Reader r = Read();
  return ReadFirst(
      r.db(), "find token", "no such token",
      "SELECT role, institution, trainee_id, label, created_unix_ms FROM tokens "
      "WHERE token_sha256_hex = ?",
      [&](const SqliteStatement& s) { return TokenRowFrom(s, token_sha256_hex); },
      token_sha256_hex);
}

StoreStatus SqliteStore::AddTrainee(const TraineeRow& t) {
  std::lock_guard lock(write_mutex_);
  int rc = SQLITE_OK;
  if (Execute(*writer_,
              "INSERT INTO trainees (trainee_id, institution, display_name, created_unix_ms) "
              "VALUES (?, ?, ?, ?)",
              &rc, t.trainee_id, t.institution, t.display_name, t.created_unix_ms)) {
    return StoreStatus::Ok();
  }
  if (rc == SQLITE_CONSTRAINT_PRIMARYKEY) {
    return StoreStatus::Error(StoreCode::kAlreadyExists,
                              "trainee '" + t.trainee_id + "' already exists");
  }
  return FromStep(*writer_, rc, "add trainee '" + t.trainee_id + "'");
}

StoreResult<TraineeRow> SqliteStore::GetTrainee(const std::string& trainee_id) {
  Reader r = Read();
  return ReadFirst(
      r.db(), "get trainee", "no trainee '" + trainee_id + "'",
      "SELECT institution, display_name, created_unix_ms FROM trainees WHERE trainee_id = ?",
      [&](const SqliteStatement& s) {
        return TraineeRow{trainee_id, s.Text(0), s.Text(1), s.Int(2)};
      },
      trainee_id);
}

StoreResult<std::vector<TraineeRow>> SqliteStore::ListTrainees(const std::string& institution,
                                                               const ListPage& page) {
  Reader r = Read();
  return ReadRows(
      r.db(), "list trainees",
      "SELECT trainee_id, institution, display_name, created_unix_ms FROM trainees "
      "WHERE institution = ? AND (? = 0 OR trainee_id > ?) ORDER BY trainee_id LIMIT ?",
      TraineeRowFrom<SqliteStatement>,
      institution, int64_t{page.has_after}, page.after_text,
      int64_t{page.limit > 0 ? page.limit : -1});
}

StoreResult<std::vector<AuditRow>> SqliteStore::ListAudit(int64_t since_unix_ms, int limit,
                                                         int64_t after_id) {
  Reader r = Read();
  return ReadRows(
      r.db(), "list audit",
      "SELECT id, at_unix_ms, actor, actor_label, role, institution, action, target, result "
      "FROM audit_log WHERE at_unix_ms >= ? AND id > ? ORDER BY id LIMIT ?",
      AuditRowFrom<SqliteStatement>, since_unix_ms, after_id, int64_t{limit});
}

StoreResult<std::vector<AuditRow>> SqliteStore::ListAuditNewest(const AuditQuery& q) {
  Reader r = Read();
  // An empty or zero filter matches every row: one statement serves all.
  return ReadRows(
      r.db(), "list audit",
      "SELECT id, at_unix_ms, actor, actor_label, role, institution, action, target, result "
      "FROM audit_log WHERE (?1 = '' OR actor = ?1 OR actor_label = ?1) "
      "AND (?2 = '' OR action = ?2) AND at_unix_ms >= ?3 AND (?4 = 0 OR at_unix_ms < ?4) "
      "AND (?5 = 0 OR id < ?5) ORDER BY id DESC LIMIT ?6",
      AuditRowFrom<SqliteStatement>, q.actor, q.action, q.from_unix_ms, q.to_unix_ms, q.before_id,
      int64_t{q.limit > 0 ? q.limit : -1});
}

StoreStatus SqliteStore::WriteAudit(const AuditRow& a) {
  SqliteStatement* s = writer_->Prepare(
      "INSERT INTO audit_log (id, at_unix_ms, actor, actor_label, role, institution, action, "
      "target, result) VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?)",
      nullptr);
  if (!s) return Internal(*writer_, "write audit");
  s->Bind(1, next_audit_id_).Bind(2, a.at_unix_ms).Bind(3, a.actor).Bind(4, a.actor_label);
  s->Bind(5, a.role).Bind(6, a.institution).Bind(7, a.action).Bind(8, a.target);
  s->Bind(9, a.result);
  int rc = SQLITE_OK;
  s->Step(&rc);
  s->Reset();
  if (rc != SQLITE_OK) return FromStep(*writer_, rc, "write audit");
  ++next_audit_id_;
  return StoreStatus::Ok();
}

}  // namespace ves::patient_db
