// SqliteStore: sessions (group-committed batches) and the station reports
// that come with them.
#include <algorithm>
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "patient_db/sqlite_store.h"
#include "patient_db/sqlite_store_internal.h"
#include "patient_db/store_rows.h"

namespace ves::patient_db {
namespace {

void BindStationRow(SqliteStatement* s, const StationRow& r) {
  const StationHealthRow& h = r.health;
  const auto u = [](uint64_t v) { return static_cast<int64_t>(v); };  // bounded by the server
  s->Bind(1, r.institution).Bind(2, r.station_id).Bind(3, r.last_seen_unix_ms);
  s->Bind(4, r.software_version).Bind(5, r.version_session_end_unix_ms);
  s->Bind(6, int64_t{r.has_health}).Bind(7, r.health_session_uuid);
  s->Bind(8, r.health_session_end_unix_ms).Bind(9, h.device).Bind(10, u(h.loop_cycles));
  s->Bind(11, h.loop_cycle_p99_us).Bind(12, h.loop_budget_us).Bind(13, u(h.loop_overruns));
  s->Bind(14, u(h.hard_faults)).Bind(15, u(h.transient_faults));
  s->Bind(16, u(h.can_bus_errors)).Bind(17, u(h.can_lost_frames));
  s->Bind(18, u(h.can_send_failures)).Bind(19, u(h.can_malformed_frames));
}

}  // namespace

StoreStatus SqliteStore::WriteSession(const SessionRow& row, SessionPutResult* result) {
  SqliteDb& db = *writer_;
  SqliteStatement* s = db.Prepare(
      std::string("SELECT ") + kSessionColumns + " FROM sessions WHERE uuid = ?", nullptr);
  if (!s) return Internal(db, "find session");
  s->Bind(1, row.uuid);
  int rc = SQLITE_OK;
  std::optional<SessionRow> first;
  if (s->Step(&rc)) first = SessionRowFrom(*s);
  s->Reset();
  if (rc != SQLITE_OK) return Internal(db, "find session");
  if (first) {
    result->outcome = first->body_sha256_hex == row.body_sha256_hex ? SessionPut::kDuplicate
                                                                    : SessionPut::kConflict;
    result->first = std::move(*first);
    return StoreStatus::Ok();
  }
  s = db.Prepare(std::string("INSERT INTO sessions (") + kSessionColumns +
                     ", body) VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)",
                 nullptr);
  if (!s) return Internal(db, "insert session");
  s->Bind(1, row.uuid).Bind(2, row.trainee_id).Bind(3, row.institution).Bind(4, row.case_id);
  s->Bind(5, int64_t{row.case_version}).Bind(6, row.station_id).Bind(7, row.start_unix_ms);
  s->Bind(8, row.end_unix_ms).Bind(9, int64_t{row.outcome}).Bind(10, int64_t{row.completed});
  s->Bind(11, row.time_to_cecum_s).Bind(12, row.pain_s).Bind(13, row.score);
  s->Bind(14, row.body_sha256_hex).Bind(15, row.stored_unix_ms).Bind(16, row.operator_kind);
  s->Bind(17, row.max_tip_arc_m).Bind(18, row.loop_s).Bind(19, row.xray_s);
  s->BindBlob(20, row.body);
  if (!Run(s, &rc)) return Internal(db, "insert session " + row.uuid);
  if (!row.lesson_id.empty()) {  // queued for the lesson judge with the session itself
    s = db.Prepare(
        "INSERT INTO lesson_sessions (session_uuid, lesson_id, trainee_id) VALUES (?, ?, ?)",
        nullptr);
    if (!s) return Internal(db, "queue lesson session");
    s->Bind(1, row.uuid).Bind(2, row.lesson_id).Bind(3, row.trainee_id);
    if (!Run(s, &rc)) return Internal(db, "queue lesson session " + row.uuid);
  }
  result->outcome = SessionPut::kStored;
  result->first = row;
  result->first.body.clear();
  result->first.lesson_id.clear();
  result->first.station.reset();
  return StoreStatus::Ok();
}

StoreStatus SqliteStore::WriteStation(const StationRow& report) {
  SqliteDb& db = *writer_;
  SqliteStatement* s = db.Prepare(std::string("SELECT ") + kStationColumns +
                                      " FROM stations WHERE institution = ? AND station_id = ?",
                                  nullptr);
  if (!s) return Internal(db, "find station");
  s->Bind(1, report.institution).Bind(2, report.station_id);
  int rc = SQLITE_OK;
  std::optional<StationRow> stored;
  if (s->Step(&rc)) stored = StationRowFrom(*s);
  s->Reset();
  if (rc != SQLITE_OK) return Internal(db, "find station");
  // The writer holds the database (BEGIN IMMEDIATE): read, merge, write back.
  const StationRow merged = MergeStationReport(stored ? &*stored : nullptr, report);
  std::string sql =
      std::string("INSERT OR REPLACE INTO stations (") + kStationColumns + ") VALUES (?";
  for (int c = 2; c <= kStationColumnCount; ++c) sql += ", ?";
  s = db.Prepare(sql + ")", nullptr);
  if (!s) return Internal(db, "write station");
  BindStationRow(s, merged);
  if (!Run(s, &rc)) return Internal(db, "write station " + report.station_id);
  return StoreStatus::Ok();
}

StoreResult<std::vector<StationRow>> SqliteStore::ListStations(const std::string& institution,
                                                               const ListPage& page) {
  Reader r = Read();
  return ReadRows(r.db(), "list stations",
                  std::string("SELECT ") + kStationColumns +
                      " FROM stations WHERE institution = ? AND (? = 0 OR station_id > ?) "
                      "ORDER BY station_id LIMIT ?",
                  StationRowFrom<SqliteStatement>, institution, int64_t{page.has_after},
                  page.after_text, int64_t{page.limit > 0 ? page.limit : -1});
}

StoreResult<std::vector<SessionPutResult>> SqliteStore::CommitBatch(const WriteBatch& batch) {
  std::lock_guard lock(write_mutex_);
  SqliteDb& db = *writer_;
  const int64_t audit_id_before = next_audit_id_;
  std::string error;
  if (!db.Exec("BEGIN IMMEDIATE", &error)) {
    return StoreStatus::Error(StoreCode::kInternal, "begin batch: " + error);
  }
  auto fail = [&](StoreStatus status) {
    db.Exec("ROLLBACK", nullptr);
    next_audit_id_ = audit_id_before;
    return status;
  };
  std::vector<SessionPutResult> results(batch.sessions.size());
  for (size_t i = 0; i < batch.sessions.size(); ++i) {
    StoreStatus st = WriteSession(batch.sessions[i], &results[i]);
    if (!st.ok()) return fail(st);
    // A refused (conflicting) upload reports nothing; a repeated one still
    // says the station was seen.
    if (batch.sessions[i].station && results[i].outcome != SessionPut::kConflict) {
      st = WriteStation(*batch.sessions[i].station);
      if (!st.ok()) return fail(st);
    }
    if (i < batch.session_audit.size()) {
      AuditRow a = batch.session_audit[i];
      a.result = SessionPutAuditResult(results[i].outcome);
      st = WriteAudit(a);
      if (!st.ok()) return fail(st);
    }
  }
  for (const AuditRow& a : batch.audit) {
    StoreStatus st = WriteAudit(a);
    if (!st.ok()) return fail(st);
  }
  // With synchronous=FULL the WAL is on disk when COMMIT returns.
  if (!db.Exec("COMMIT", &error)) {
    return fail(StoreStatus::Error(StoreCode::kInternal, "commit batch: " + error));
  }
  return results;
}

StoreResult<SessionRow> SqliteStore::GetSession(const std::string& uuid) {
  Reader r = Read();
  return ReadFirst(
      r.db(), "get session", "no session '" + uuid + "'",
      std::string("SELECT ") + kSessionColumns + kSessionLessonColumn +
          ", body FROM sessions WHERE uuid = ?",
      [](const SqliteStatement& s) {
        SessionRow row = SessionWithLessonFrom(s);
        row.body = s.Blob(kSessionColumnCount + 1);
        return row;
      },
      uuid);
}

StoreResult<std::vector<SessionRow>> SqliteStore::ListSessions(const std::string& trainee_id,
                                                               const std::string& case_id,
                                                               const ListPage& page) {
  Reader r = Read();
  std::string sql = std::string("SELECT ") + kSessionColumns + kSessionLessonColumn +
                    " FROM sessions WHERE trainee_id = ?";
  if (!case_id.empty()) sql += " AND case_id = ?";
  if (page.has_after) sql += " AND (start_unix_ms > ? OR (start_unix_ms = ? AND uuid > ?))";
  sql += " ORDER BY start_unix_ms, uuid LIMIT ?";
  SqliteStatement* s = r.db().Prepare(sql, nullptr);
  if (!s) return Internal(r.db(), "list sessions");
  int i = 1;
  s->Bind(i++, trainee_id);
  if (!case_id.empty()) s->Bind(i++, case_id);
  if (page.has_after) {
    s->Bind(i, page.after_number).Bind(i + 1, page.after_number).Bind(i + 2, page.after_text);
    i += 3;
  }
  s->Bind(i, int64_t{page.limit > 0 ? page.limit : -1});
  int rc = SQLITE_OK;
  std::vector<SessionRow> out;
  while (s->Step(&rc)) out.push_back(SessionWithLessonFrom(*s));
  s->Reset();
  if (rc != SQLITE_OK) return Internal(r.db(), "list sessions");
  return out;
}

StoreResult<std::vector<std::vector<SessionRow>>> SqliteStore::ListSessionsOf(
    const std::vector<std::string>& trainee_ids, int64_t from_unix_ms, int64_t to_unix_ms,
    int limit_each) {
  Reader r = Read();
  std::map<std::string, std::vector<SessionRow>> of;
  StoreStatus st = ForEachRow(
      r.db(), "list sessions of trainees",
      std::string("SELECT ") + kSessionColumns + kSessionLessonColumn +
          " FROM sessions WHERE trainee_id IN (SELECT value FROM json_each(?))"
          " AND start_unix_ms >= ? AND (? = 0 OR start_unix_ms < ?)",
      [&](const SqliteStatement& s) {
        SessionRow row = SessionWithLessonFrom(s);
        of[row.trainee_id].push_back(std::move(row));
      },
      JsonStringArray(trainee_ids), from_unix_ms, to_unix_ms, to_unix_ms);
  if (!st.ok()) return st;
  // ListSessions' order, sorted here rather than by SQLite (as the verdicts
  // of ListLessonVerdictsOf are: SQLite's sort of a whole group's rows is
  // the slower part).
  for (auto& [trainee, rows] : of) {
    std::sort(rows.begin(), rows.end(), [](const auto& a, const auto& b) {
      return std::tie(a.start_unix_ms, a.uuid) < std::tie(b.start_unix_ms, b.uuid);
    });
    if (limit_each >= 0 && rows.size() > static_cast<size_t>(limit_each) + 1) {
      rows.resize(static_cast<size_t>(limit_each) + 1);
    }
  }
  return InKeyOrder(trainee_ids, std::move(of));
}

StoreResult<std::vector<TraineeActivity>> SqliteStore::GetTraineeActivity(
    const std::vector<std::string>& trainee_ids) {
  Reader r = Read();
  std::map<std::string, TraineeActivity> of;
  StoreStatus st = ForEachRow(
      r.db(), "trainee activity",
      "SELECT trainee_id, COUNT(*), MAX(end_unix_ms) FROM sessions "
      "WHERE trainee_id IN (SELECT value FROM json_each(?)) GROUP BY trainee_id",
      [&](const SqliteStatement& s) {
        of[s.Text(0)] = {s.Int(1), s.Int(2)};
      },
      JsonStringArray(trainee_ids));
  if (!st.ok()) return st;
  return InKeyOrder(trainee_ids, std::move(of));
}

StoreResult<std::vector<SessionRow>> SqliteStore::ListOperatorSessions(
    const std::string& institution, const std::string& case_id, const std::string& operator_kind,
    int limit) {
  Reader r = Read();
  return ReadRows(r.db(), "list operator sessions",
                  std::string("SELECT ") + kSessionColumns +
                      " FROM sessions WHERE institution = ? AND case_id = ? AND operator_kind = ?"
                      " ORDER BY start_unix_ms DESC, uuid DESC LIMIT ?",
                  SessionRowFrom<SqliteStatement>, institution, case_id, operator_kind,
                  int64_t{limit});
}

StoreResult<int64_t> SqliteStore::CountSessions() {
  Reader r = Read();
  return ReadFirst(r.db(), "count sessions", "no count", "SELECT COUNT(*) FROM sessions",
                   [](const SqliteStatement& s) { return s.Int(0); });
}

}  // namespace ves::patient_db
