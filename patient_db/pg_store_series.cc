// PgStore: the web pages' session series (docs/web.md, "Session series").
// Schema: migration 6, the same SQL as SQLite.
#include <pqxx/pqxx>

#include "patient_db/pg_store.h"
#include "patient_db/pg_store_internal.h"
#include "patient_db/store_rows.h"

namespace ves::patient_db {

StoreStatus PgStore::PutSessionSeries(const SessionSeriesRow& row) {
  StoreStatus bad = CheckSessionSeries(row);
  if (!bad.ok()) return bad;
  StoreStatus st = Transact("put session series", TxMode::kWrite, [&](pqxx::transaction_base& tx) {
    tx.exec_params(
        "INSERT INTO session_series (session_uuid, format_version, computed_unix_ms, series) "
        "VALUES ($1, $2, $3, $4) ON CONFLICT (session_uuid) DO UPDATE SET "
        "format_version = excluded.format_version, computed_unix_ms = excluded.computed_unix_ms, "
        "series = excluded.series",
        row.session_uuid, int64_t{row.format_version}, row.computed_unix_ms,
        pqxx::binarystring(row.json));
    return StoreStatus::Ok();
  });
  // A foreign key violation: the session is not stored.
  if (st.code == StoreCode::kInvalidArgument) {
    return StoreStatus::Error(StoreCode::kNotFound, "no session '" + row.session_uuid + "'");
  }
  return st;
}

StoreResult<SessionSeriesRow> PgStore::GetSessionSeries(const std::string& session_uuid) {
  return Query<SessionSeriesRow>(
      "get session series", [&](pqxx::transaction_base& tx) -> StoreResult<SessionSeriesRow> {
        pqxx::result r = tx.exec_params(
            "SELECT session_uuid, format_version, computed_unix_ms, series FROM session_series "
            "WHERE session_uuid = $1",
            session_uuid);
        if (r.empty()) {
          return StoreStatus::Error(StoreCode::kNotFound, "no series for '" + session_uuid + "'");
        }
        return SeriesRowFrom(PgColumns(r[0]));
      });
}

}  // namespace ves::patient_db
