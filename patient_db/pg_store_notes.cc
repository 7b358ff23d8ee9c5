// PgStore: supervisors' notes and sign-offs on sessions (docs/web.md, "Notes
// and sign-off"). Schema: migration 9, the same SQL as SQLite.
#include <pqxx/pqxx>

#include "patient_db/pg_store.h"
#include "patient_db/pg_store_internal.h"
#include "patient_db/store_rows.h"

namespace ves::patient_db {
StoreStatus PgStore::AddSessionNote(const SessionNoteRow& row) {
  StoreStatus bad = CheckSessionNote(row);
  if (!bad.ok()) return bad;
  return Transact("add session note", TxMode::kWrite, [&](pqxx::transaction_base& tx) {
    if (tx.exec_params("SELECT 1 FROM sessions WHERE uuid = $1", row.session_uuid).empty()) {
      return StoreStatus::Error(StoreCode::kNotFound, "no session '" + row.session_uuid + "'");
    }
    pqxx::result r = tx.exec_params(
        "INSERT INTO session_notes (note_id, session_uuid, author, author_label, "
        "written_unix_ms, text) VALUES ($1, $2, $3, $4, $5, $6) "
        "ON CONFLICT (note_id) DO NOTHING RETURNING 1",
        row.note_id, row.session_uuid, row.author, row.author_label, row.written_unix_ms, row.text);
    if (r.empty()) {
      return StoreStatus::Error(StoreCode::kAlreadyExists,
                                "note id '" + row.note_id + "' is taken");
    }
    return StoreStatus::Ok();
  });
}

StoreResult<std::vector<SessionNoteRow>> PgStore::ListSessionNotes(const std::string& session_uuid,
                                                                   int limit) {
  return Query<std::vector<SessionNoteRow>>("list session notes", [&](pqxx::transaction_base& tx) {
    return RowsOf(tx.exec_params(std::string("SELECT ") + kNoteColumns +
                                     " FROM session_notes WHERE session_uuid = $1 ORDER BY "
                                     "written_unix_ms, note_id LIMIT $2",
                                 session_uuid, int64_t{limit}),
                  NoteRowFrom<PgColumns>);
  });
}

StoreResult<bool> PgStore::SignOffSession(const SessionSignOffRow& row) {
  return InsertOncePerSession(
      "sign off session", row.session_uuid,
      std::string("INSERT INTO session_sign_offs (") + kSignOffColumns +
          ") VALUES ($1, $2, $3, $4) ON CONFLICT (session_uuid) DO NOTHING RETURNING 1",
      row.session_uuid, row.signed_by, row.signed_by_label, row.signed_unix_ms);
}

StoreResult<SessionSignOffRow> PgStore::GetSessionSignOff(const std::string& session_uuid) {
  return Query<SessionSignOffRow>(
      "get sign-off", [&](pqxx::transaction_base& tx) -> StoreResult<SessionSignOffRow> {
        pqxx::result r = tx.exec_params(std::string("SELECT ") + kSignOffColumns +
                                            " FROM session_sign_offs WHERE session_uuid = $1",
                                        session_uuid);
        if (r.empty()) {
          return StoreStatus::Error(StoreCode::kNotFound,
                                    "session '" + session_uuid + "' not signed off");
        }
        return SignOffRowFrom(PgColumns(r[0]));
      });
}

StoreResult<std::vector<SessionSignOffRow>> PgStore::ListTraineeSignOffs(
    const std::string& trainee_id) {
  return Query<std::vector<SessionSignOffRow>>("list sign-offs", [&](pqxx::transaction_base& tx) {
    return RowsOf(tx.exec_params("SELECT o.session_uuid, o.signed_by, o.signed_by_label, "
                                 "o.signed_unix_ms FROM session_sign_offs o JOIN sessions s "
                                 "ON s.uuid = o.session_uuid WHERE s.trainee_id = $1",
                                 trainee_id),
                  SignOffRowFrom<PgColumns>);
  });
}

}  // namespace ves::patient_db
