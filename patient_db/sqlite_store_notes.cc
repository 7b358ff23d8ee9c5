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
  auto session = ReadFirst(
      *writer_, "add session note", "no session '" + row.session_uuid + "'",
      "SELECT 1 FROM sessions WHERE uuid = ?", [](const SqliteStatement&) { return true; },
      row.session_uuid);
  if (!session.ok()) return session.status;
  int rc = SQLITE_OK;
  if (Execute(
          *writer_,
          std::string("INSERT INTO session_notes (") + kNoteColumns + ") VALUES (?, ?, ?, ?, ?, ?)",
          &rc, row.note_id, row.session_uuid, row.author, row.author_label, row.written_unix_ms,
          row.text)) {
    return StoreStatus::Ok();
  }
  if (IsConstraint(rc)) {
    return StoreStatus::Error(StoreCode::kAlreadyExists, "note id '" + row.note_id + "' is taken");
  }
  return Internal(*writer_, "add session note");
}

StoreResult<std::vector<SessionNoteRow>> SqliteStore::ListSessionNotes(
    const std::string& session_uuid, int limit) {
  Reader r = Read();
  return ReadRows(
      r.db(), "list session notes",
      std::string("SELECT ") + kNoteColumns +
          " FROM session_notes WHERE session_uuid = ? ORDER BY written_unix_ms, note_id LIMIT ?",
      NoteRowFrom<SqliteStatement>,
      session_uuid, int64_t{limit});
}

StoreResult<bool> SqliteStore::SignOffSession(const SessionSignOffRow& row) {
  std::lock_guard lock(write_mutex_);
  return InsertOncePerSession(*writer_, "sign off session", row.session_uuid,
                              std::string("INSERT INTO session_sign_offs (") + kSignOffColumns +
                                  ") VALUES (?, ?, ?, ?) ON CONFLICT (session_uuid) DO NOTHING",
                              row.session_uuid, row.signed_by, row.signed_by_label,
                              row.signed_unix_ms);
}

StoreResult<SessionSignOffRow> SqliteStore::GetSessionSignOff(const std::string& session_uuid) {
  Reader r = Read();
  return ReadFirst(
      r.db(), "get sign-off", "session '" + session_uuid + "' not signed off",
      std::string("SELECT ") + kSignOffColumns + " FROM session_sign_offs WHERE session_uuid = ?",
      SignOffRowFrom<SqliteStatement>, session_uuid);
}

StoreResult<std::vector<SessionSignOffRow>> SqliteStore::ListTraineeSignOffs(
    const std::string& trainee_id) {
  Reader r = Read();
  return ReadRows(r.db(), "list sign-offs",
                  "SELECT o.session_uuid, o.signed_by, o.signed_by_label, o.signed_unix_ms "
                  "FROM session_sign_offs o JOIN sessions s ON s.uuid = o.session_uuid "
                  "WHERE s.trainee_id = ?",
                  SignOffRowFrom<SqliteStatement>, trainee_id);
}

}  // namespace ves::patient_db
