// SqliteStore: supervisors' notes and sign-offs on sessions (docs/web.md,
// "Notes and sign-off"). Schema: migration 9.
#include <optional>

#include "patient_db/sqlite_store.h"
#include "patient_db/sqlite_store_internal.h"
#include "patient_db/store_rows.h"

namespace ves::patient_db {
StoreStatus SqliteStore::AddSessionNote(const SessionNoteRow& row) {
  StoreStatus bad = CheckSessionNote(row);
  if (!bad.ok()) return bad;
  std::lock_guard lock(write_mutex_);
  // The session first: a foreign key and a taken note id are both constraint
  // failures, and they answer differently.
  SqliteStatement* exists = writer_->Prepare("SELECT 1 FROM sessions WHERE uuid = ?", nullptr);
  if (!exists) return Internal(*writer_, "add session note");
  exists->Bind(1, row.session_uuid);
  int rc = SQLITE_OK;
  const bool found = exists->Step(&rc);
  exists->Reset();
  if (rc != SQLITE_OK) return Internal(*writer_, "add session note");
  if (!found)
    return StoreStatus::Error(StoreCode::kNotFound, "no session '" + row.session_uuid + "'");
  SqliteStatement* s = writer_->Prepare(
      std::string("INSERT INTO session_notes (") + kNoteColumns + ") VALUES (?, ?, ?, ?, ?, ?)",
      nullptr);
  if (!s) return Internal(*writer_, "add session note");
  s->Bind(1, row.note_id).Bind(2, row.session_uuid).Bind(3, row.author);
  s->Bind(4, row.author_label).Bind(5, row.written_unix_ms).Bind(6, row.text);
  s->Step(&rc);
  s->Reset();
  if (IsConstraint(rc)) {
    return StoreStatus::Error(StoreCode::kAlreadyExists, "note id '" + row.note_id + "' is taken");
  }
  if (rc != SQLITE_OK) return Internal(*writer_, "add session note");
  return StoreStatus::Ok();
}

StoreResult<std::vector<SessionNoteRow>> SqliteStore::ListSessionNotes(
    const std::string& session_uuid, int limit) {
  Reader r = Read();
  SqliteStatement* s = r.db().Prepare(
      std::string("SELECT ") + kNoteColumns +
          " FROM session_notes WHERE session_uuid = ? ORDER BY written_unix_ms, note_id LIMIT ?",
      nullptr);
  if (!s) return Internal(r.db(), "list session notes");
  s->Bind(1, session_uuid).Bind(2, int64_t{limit});
  int rc = SQLITE_OK;
  std::vector<SessionNoteRow> out;
  while (s->Step(&rc)) {
    out.push_back({s->Text(0), s->Text(1), s->Text(2), s->Text(3), s->Int(4), s->Text(5)});
  }
  s->Reset();
  if (rc != SQLITE_OK) return Internal(r.db(), "list session notes");
  return out;
}

StoreResult<bool> SqliteStore::SignOffSession(const SessionSignOffRow& row) {
  std::lock_guard lock(write_mutex_);
  SqliteStatement* s =
      writer_->Prepare(std::string("INSERT INTO session_sign_offs (") + kSignOffColumns +
                           ") VALUES (?, ?, ?, ?) ON CONFLICT (session_uuid) DO NOTHING",
                       nullptr);
  if (!s) return Internal(*writer_, "sign off session");
  s->Bind(1, row.session_uuid).Bind(2, row.signed_by).Bind(3, row.signed_by_label);
  s->Bind(4, row.signed_unix_ms);
  int rc = SQLITE_OK;
  s->Step(&rc);
  s->Reset();
  if (IsConstraint(rc)) {  // the foreign key: no such session
    return StoreStatus::Error(StoreCode::kNotFound, "no session '" + row.session_uuid + "'");
  }
  if (rc != SQLITE_OK) return Internal(*writer_, "sign off session");
  return sqlite3_changes(writer_->raw()) > 0;
}

StoreResult<SessionSignOffRow> SqliteStore::GetSessionSignOff(const std::string& session_uuid) {
  Reader r = Read();
  SqliteStatement* s = r.db().Prepare(
      std::string("SELECT ") + kSignOffColumns + " FROM session_sign_offs WHERE session_uuid = ?",
      nullptr);
  if (!s) return Internal(r.db(), "get sign-off");
  s->Bind(1, session_uuid);
  int rc = SQLITE_OK;
  std::optional<SessionSignOffRow> row;
  if (s->Step(&rc)) row = SignOffRowFrom(*s);
  s->Reset();
  if (rc != SQLITE_OK) return Internal(r.db(), "get sign-off");
  if (!row) {
    return StoreStatus::Error(StoreCode::kNotFound,
                              "session '" + session_uuid + "' not signed off");
  }
  return std::move(*row);
}

StoreResult<std::vector<SessionSignOffRow>> SqliteStore::ListTraineeSignOffs(
    const std::string& trainee_id) {
  Reader r = Read();
  SqliteStatement* s = r.db().Prepare(
      "SELECT o.session_uuid, o.signed_by, o.signed_by_label, o.signed_unix_ms "
      "FROM session_sign_offs o JOIN sessions s ON s.uuid = o.session_uuid "
      "WHERE s.trainee_id = ?",
      nullptr);
  if (!s) return Internal(r.db(), "list sign-offs");
  s->Bind(1, trainee_id);
  int rc = SQLITE_OK;
  std::vector<SessionSignOffRow> out;
  while (s->Step(&rc)) out.push_back(SignOffRowFrom(*s));
  s->Reset();
  if (rc != SQLITE_OK) return Internal(r.db(), "list sign-offs");
  return out;
}

}  // namespace ves::patient_db
