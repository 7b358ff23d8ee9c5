// SqliteStore: the web pages' session series (docs/web.md, "Session
// series"). Schema: migration 6.
#include <optional>

#include "patient_db/sqlite_store.h"
#include "patient_db/sqlite_store_internal.h"
#include "patient_db/store_rows.h"

namespace ves::patient_db {
StoreStatus SqliteStore::PutSessionSeries(const SessionSeriesRow& row) {
  StoreStatus bad = CheckSessionSeries(row);
  if (!bad.ok()) return bad;
  std::lock_guard lock(write_mutex_);
  SqliteStatement* s = writer_->Prepare(
      "INSERT INTO session_series (session_uuid, format_version, computed_unix_ms, series) "
      "VALUES (?, ?, ?, ?) ON CONFLICT (session_uuid) DO UPDATE SET "
      "format_version = excluded.format_version, computed_unix_ms = excluded.computed_unix_ms, "
      "series = excluded.series",
      nullptr);
  if (!s) return Internal(*writer_, "put session series");
  s->Bind(1, row.session_uuid).Bind(2, int64_t{row.format_version});
  s->Bind(3, row.computed_unix_ms).BindBlob(4, row.json);
  int rc = SQLITE_OK;
  Run(s, &rc);
  if (IsConstraint(rc)) {
    return StoreStatus::Error(StoreCode::kNotFound, "no session '" + row.session_uuid + "'");
  }
  if (rc != SQLITE_OK) return Internal(*writer_, "put session series");
  return StoreStatus::Ok();
}

StoreResult<SessionSeriesRow> SqliteStore::GetSessionSeries(const std::string& session_uuid) {
  Reader r = Read();
  return ReadFirst(
      r.db(), "get session series", "no series for '" + session_uuid + "'",
      "SELECT session_uuid, format_version, computed_unix_ms, series FROM session_series "
      "WHERE session_uuid = ?",
      SeriesRowFrom<SqliteStatement>,
      session_uuid);
}

}  // namespace ves::patient_db
