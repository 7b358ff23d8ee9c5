// PgStore: sessions (group-committed batches) and the station reports that
// come with them.
// Races between replicas are settled by the primary keys with INSERT ... ON
// CONFLICT DO NOTHING: the loser waits for the winner's transaction and then
// reads its row, so no error reaches the caller.
#include <algorithm>
#include <cstdint>
#include <map>
#include <numeric>
#include <pqxx/pqxx>
#include <set>
#include <stdexcept>
#include <string>
#include <tuple>
#include <vector>

#include "patient_db/pg_store.h"
#include "patient_db/pg_store_internal.h"
#include "patient_db/store_rows.h"

namespace ves::patient_db {
namespace {

// The 19 column values of kStationColumns, in order, as text parameters.
std::vector<std::string> StationParams(const StationRow& r) {
  const StationHealthRow& h = r.health;
  return {r.institution,
          r.station_id,
          std::to_string(r.last_seen_unix_ms),
          r.software_version,
          std::to_string(r.version_session_end_unix_ms),
          r.has_health ? "1" : "0",
          r.health_session_uuid,
          std::to_string(r.health_session_end_unix_ms),
          h.device,
          std::to_string(h.loop_cycles),
          pqxx::to_string(h.loop_cycle_p99_us),
          pqxx::to_string(h.loop_budget_us),
          std::to_string(h.loop_overruns),
          std::to_string(h.hard_faults),
          std::to_string(h.transient_faults),
          std::to_string(h.can_bus_errors),
          std::to_string(h.can_lost_frames),
          std::to_string(h.can_send_failures),
          std::to_string(h.can_malformed_frames)};
}

// Merges one upload's report into its station's row. A new station is
// inserted; a present one is locked (FOR UPDATE: another replica's upload
// from the same station waits), merged and written back.
void WriteStation(pqxx::transaction_base& tx, const StationRow& report) {
  std::string values;
  for (int c = 1; c <= 19; ++c) values += (c == 1 ? "$" : ", $") + std::to_string(c);
  const pqxx::result inserted = tx.exec_params(
      std::string("INSERT INTO stations (") + kStationColumns + ") VALUES (" + values +
          ") ON CONFLICT (institution, station_id) DO NOTHING RETURNING station_id",
      pqxx::prepare::make_dynamic_params(StationParams(report)));
  if (!inserted.empty()) return;
  const pqxx::result found =
      tx.exec_params(std::string("SELECT ") + kStationColumns +
                         " FROM stations WHERE institution = $1 AND station_id = $2 FOR UPDATE",
                     report.institution, report.station_id);
  if (found.empty()) throw std::runtime_error("station " + report.station_id + " vanished");
  const StationRow stored = StationRowFrom(PgColumns(found[0]));
  const StationRow merged = MergeStationReport(&stored, report);
  std::string sql = "UPDATE stations SET ";
  const std::string columns = kStationColumns;
  size_t start = 0;
  for (int c = 1; c <= 19; ++c) {
    const size_t comma = columns.find(", ", start);
    const std::string name =
        columns.substr(start, comma == std::string::npos ? std::string::npos : comma - start);
    start = comma + 2;
    if (c <= 2) continue;  // the key
    sql += (c == 3 ? "" : ", ") + name + " = $" + std::to_string(c);
  }
  sql += " WHERE institution = $1 AND station_id = $2";
  tx.exec_params(sql, pqxx::prepare::make_dynamic_params(StationParams(merged)));
}

// Appends `rows` in order in one statement; ids come from audit_log_id_seq
// (PgMigrations), shared by all replicas.
void WriteAudit(pqxx::transaction_base& tx, const std::vector<AuditRow>& rows) {
  if (rows.empty()) return;
  std::string sql =
      "INSERT INTO audit_log (at_unix_ms, actor, actor_label, role, institution, action, "
      "target, result) SELECT at, actor, label, role, inst, action, target, result FROM "
      "(VALUES ";
  std::vector<std::string> params;
  for (size_t k = 0; k < rows.size(); ++k) {
    const AuditRow& a = rows[k];
    const size_t p = params.size();
    sql += (k ? ", (" : "(") + std::to_string(k) + ", $" + std::to_string(p + 1) + "::BIGINT";
    for (size_t c = 2; c <= 8; ++c) sql += ", $" + std::to_string(p + c);
    sql += ")";
    for (const std::string& v : {std::to_string(a.at_unix_ms), a.actor, a.actor_label, a.role,
                                 a.institution, a.action, a.target, a.result}) {
      params.push_back(v);
    }
  }
  // ORDER BY the position so the ids follow the batch order.
  sql += ") AS v(pos, at, actor, label, role, inst, action, target, result) ORDER BY pos";
  tx.exec_params(sql, pqxx::prepare::make_dynamic_params(params));
}

// bytea in PostgreSQL's hex input format, so binary bodies travel as text parameters.
std::string ByteaHex(const std::string& bytes) {
  static const char kHex[] = "0123456789abcdef";
  std::string out = "\\x";
  out.reserve(2 + 2 * bytes.size());
  for (unsigned char c : bytes) {
    out += kHex[c >> 4];
    out += kHex[c & 0xf];
  }
  return out;
}

// The multi-row INSERT of the batch's sessions, its parameters in *params;
// "" for no sessions. Rows go in uuid order (stable, so repeats keep batch
// order) so two replicas committing overlapping batches lock the same keys in
// the same order and cannot deadlock; audit rows are then written in batch
// order. Each step of a commit is one multi-row statement, whatever the
// batch size.
std::string SessionsInsert(const WriteBatch& batch, std::vector<std::string>* params) {
  if (batch.sessions.empty()) return "";
  std::vector<size_t> order(batch.sessions.size());
  std::iota(order.begin(), order.end(), size_t{0});
  std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) {
    return batch.sessions[a].uuid < batch.sessions[b].uuid;
  });
  std::string insert = std::string("INSERT INTO sessions (") + kSessionColumns + ", body) VALUES ";
  for (size_t k = 0; k < order.size(); ++k) {
    const SessionRow& row = batch.sessions[order[k]];
    insert += k == 0 ? "(" : ", (";
    for (int c = 1; c <= 20; ++c) {
      insert += (c == 1 ? "$" : ", $") + std::to_string(params->size() + c);
    }
    insert += ")";
    for (const std::string& v : {row.uuid,
                                 row.trainee_id,
                                 row.institution,
                                 row.case_id,
                                 std::to_string(row.case_version),
                                 row.station_id,
                                 std::to_string(row.start_unix_ms),
                                 std::to_string(row.end_unix_ms),
                                 std::to_string(row.outcome),
                                 std::string(row.completed ? "1" : "0"),
                                 pqxx::to_string(row.time_to_cecum_s),
                                 pqxx::to_string(row.pain_s),
                                 pqxx::to_string(row.score),
                                 row.body_sha256_hex,
                                 std::to_string(row.stored_unix_ms),
                                 row.operator_kind,
                                 pqxx::to_string(row.max_tip_arc_m),
                                 pqxx::to_string(row.loop_s),
                                 pqxx::to_string(row.xray_s),
                                 ByteaHex(row.body)}) {
      params->push_back(v);
    }
  }
  // A uuid already stored (or repeated in this batch) is skipped here and
  // looked up after: the first stored row decides duplicate or conflict.
  return insert + " ON CONFLICT (uuid) DO NOTHING RETURNING uuid";
}

// Station reports of the sessions not refused, in key order (as the
// sessions, so replicas lock stations in the same order).
void WriteStationReports(pqxx::transaction_base& tx, const WriteBatch& batch,
                         const std::vector<SessionPutResult>& results) {
  std::vector<const StationRow*> reports;
  for (size_t i = 0; i < batch.sessions.size(); ++i) {
    const auto& station = batch.sessions[i].station;
    if (station && results[i].outcome != SessionPut::kConflict) reports.push_back(&*station);
  }
  std::stable_sort(reports.begin(), reports.end(), [](const StationRow* a, const StationRow* b) {
    return std::tie(a->institution, a->station_id) < std::tie(b->institution, b->station_id);
  });
  for (const StationRow* report : reports) WriteStation(tx, *report);
}

}  // namespace

StoreResult<std::vector<SessionPutResult>> PgStore::CommitBatch(const WriteBatch& batch) {
  std::vector<std::string> params;
  const std::string insert = SessionsInsert(batch, &params);
  std::vector<SessionPutResult> results;
  StoreStatus st = Transact("commit batch", TxMode::kWrite, [&](pqxx::transaction_base& tx) {
    results.assign(batch.sessions.size(), SessionPutResult{});
    std::set<std::string> inserted;
    if (!insert.empty()) {
      for (const auto& r : tx.exec_params(insert, pqxx::prepare::make_dynamic_params(params))) {
        inserted.insert(r[0].as<std::string>());
      }
    }
    // Stored by this batch: the first occurrence of each inserted uuid.
    std::map<std::string, SessionRow> first;
    std::vector<std::string> lookup;
    for (size_t i = 0; i < batch.sessions.size(); ++i) {
      const SessionRow& row = batch.sessions[i];
      if (first.count(row.uuid)) continue;
      if (inserted.count(row.uuid)) {
        first[row.uuid] = row;
        first[row.uuid].body.clear();
        first[row.uuid].lesson_id.clear();
        first[row.uuid].station.reset();
        results[i].outcome = SessionPut::kStored;
        if (!row.lesson_id.empty()) {  // queued for the lesson judge with the session itself
          tx.exec_params(
              "INSERT INTO lesson_sessions (session_uuid, lesson_id, trainee_id) "
              "VALUES ($1, $2, $3)",
              row.uuid, row.lesson_id, row.trainee_id);
        }
      } else {
        lookup.push_back(row.uuid);
        first[row.uuid] = SessionRow{};  // filled in below
      }
    }
    // Present before (or committed a moment ago by another replica: ON
    // CONFLICT waited for it, and this statement sees it).
    if (!lookup.empty()) {
      std::string find =
          std::string("SELECT ") + kSessionColumns + " FROM sessions WHERE uuid IN (";
      for (size_t k = 0; k < lookup.size(); ++k) find += (k ? ", $" : "$") + std::to_string(k + 1);
      find += ")";
      for (const auto& r : tx.exec_params(find, pqxx::prepare::make_dynamic_params(lookup))) {
        SessionRow found = SessionRowFrom(PgColumns(r));
        first[found.uuid] = std::move(found);
      }
    }
    std::set<std::string> seen;
    for (size_t i = 0; i < batch.sessions.size(); ++i) {
      const SessionRow& row = batch.sessions[i];
      const SessionRow& stored = first[row.uuid];
      if (stored.uuid.empty()) return StoreStatus::Error(StoreCode::kInternal, "lost " + row.uuid);
      results[i].first = stored;
      const bool stored_here = inserted.count(row.uuid) && seen.insert(row.uuid).second;
      if (stored_here) continue;  // kStored, set above
      results[i].outcome = stored.body_sha256_hex == row.body_sha256_hex ? SessionPut::kDuplicate
                                                                         : SessionPut::kConflict;
    }
    WriteStationReports(tx, batch, results);
    std::vector<AuditRow> audit;
    for (size_t i = 0; i < batch.sessions.size() && i < batch.session_audit.size(); ++i) {
      audit.push_back(batch.session_audit[i]);
      audit.back().result = SessionPutAuditResult(results[i].outcome);
    }
    audit.insert(audit.end(), batch.audit.begin(), batch.audit.end());
    WriteAudit(tx, audit);
    return StoreStatus::Ok();
  });
  // A constraint failure (a session of an unknown trainee) fails the whole
  // batch, as in SQLite, where it is an internal error.
  if (st.code == StoreCode::kInvalidArgument) st.code = StoreCode::kInternal;
  if (!st.ok()) return st;
  return results;
}

StoreResult<SessionRow> PgStore::GetSession(const std::string& uuid) {
  return Query<SessionRow>(
      "get session", [&](pqxx::transaction_base& tx) -> StoreResult<SessionRow> {
        pqxx::result r =
            tx.exec_params(std::string("SELECT ") + kSessionColumns + kSessionLessonColumn +
                               ", body FROM sessions WHERE uuid = $1",
                           uuid);
        if (r.empty()) return StoreStatus::Error(StoreCode::kNotFound, "no session '" + uuid + "'");
        SessionRow out = SessionWithLessonFrom(PgColumns(r[0]));
        out.body = pqxx::binarystring(r[0][kSessionColumnCount + 1]).str();
        return out;
      });
}

StoreResult<std::vector<SessionRow>> PgStore::ListSessions(const std::string& trainee_id,
                                                           const std::string& case_id,
                                                           const ListPage& page) {
  const std::string sql = std::string("SELECT ") + kSessionColumns + kSessionLessonColumn +
                          " FROM sessions WHERE trainee_id = $1 AND ($2 = '' OR case_id = $2)"
                          " AND ($3 = 0 OR start_unix_ms > $4 OR (start_unix_ms = $4 AND "
                          "uuid COLLATE \"C\" > $5))"
                          " ORDER BY start_unix_ms, uuid COLLATE \"C\" LIMIT $6";
  return Query<std::vector<SessionRow>>("list sessions", [&](pqxx::transaction_base& tx) {
    return RowsOf(
        tx.exec_params(sql, trainee_id, case_id, page.has_after ? 1 : 0, page.after_number,
                       page.after_text, page.limit > 0 ? int64_t{page.limit} : int64_t{1} << 62),
        SessionWithLessonFrom<PgColumns>);
  });
}

StoreResult<std::vector<std::vector<SessionRow>>> PgStore::ListSessionsOf(
    const std::vector<std::string>& trainee_ids, int64_t from_unix_ms, int64_t to_unix_ms,
    int limit_each) {
  const std::string sql = std::string("SELECT ") + kSessionColumns + kSessionLessonColumn +
                          " FROM sessions WHERE trainee_id IN "
                          "(SELECT json_array_elements_text($1::json))"
                          " AND start_unix_ms >= $2 AND ($3 = 0 OR start_unix_ms < $3)"
                          " ORDER BY start_unix_ms, uuid COLLATE \"C\"";
  return Query<std::vector<std::vector<SessionRow>>>(
      "list sessions of trainees", [&](pqxx::transaction_base& tx) {
        std::map<std::string, std::vector<SessionRow>> of;
        for (const auto& row :
             tx.exec_params(sql, JsonStringArray(trainee_ids), from_unix_ms, to_unix_ms)) {
          SessionRow s = SessionWithLessonFrom(PgColumns(row));
          std::vector<SessionRow>& rows = of[s.trainee_id];
          if (limit_each < 0 || rows.size() <= static_cast<size_t>(limit_each)) {
            rows.push_back(std::move(s));
          }
        }
        return InKeyOrder(trainee_ids, std::move(of));
      });
}

StoreResult<std::vector<TraineeActivity>> PgStore::GetTraineeActivity(
    const std::vector<std::string>& trainee_ids) {
  return Query<std::vector<TraineeActivity>>("trainee activity", [&](pqxx::transaction_base& tx) {
    std::map<std::string, TraineeActivity> of;
    for (const auto& r :
         tx.exec_params("SELECT trainee_id, COUNT(*), MAX(end_unix_ms) FROM sessions "
                        "WHERE trainee_id IN (SELECT json_array_elements_text($1::json)) "
                        "GROUP BY trainee_id",
                        JsonStringArray(trainee_ids))) {
      of[r[0].as<std::string>()] = {r[1].as<int64_t>(), r[2].as<int64_t>()};
    }
    return InKeyOrder(trainee_ids, std::move(of));
  });
}

StoreResult<std::vector<StationRow>> PgStore::ListStations(const std::string& institution,
                                                           const ListPage& page) {
  return Query<std::vector<StationRow>>("list stations", [&](pqxx::transaction_base& tx) {
    // COLLATE "C": byte order, as SQLite sorts.
    return RowsOf(
        tx.exec_params(std::string("SELECT ") + kStationColumns +
                           " FROM stations WHERE institution = $1 AND ($2 = 0 OR station_id "
                           "COLLATE \"C\" > $3) ORDER BY station_id COLLATE \"C\" LIMIT $4",
                       institution, page.has_after ? 1 : 0, page.after_text,
                       page.limit > 0 ? int64_t{page.limit} : int64_t{1} << 62),
        StationRowFrom<PgColumns>);
  });
}

StoreResult<std::vector<SessionRow>> PgStore::ListOperatorSessions(const std::string& institution,
                                                                   const std::string& case_id,
                                                                   const std::string& operator_kind,
                                                                   int limit) {
  const std::string sql = std::string("SELECT ") + kSessionColumns +
                          " FROM sessions WHERE institution = $1 AND case_id = $2 AND "
                          "operator_kind = $3 ORDER BY start_unix_ms DESC, uuid COLLATE \"C\" "
                          "DESC LIMIT $4";
  return Query<std::vector<SessionRow>>("list operator sessions", [&](pqxx::transaction_base& tx) {
    return RowsOf(tx.exec_params(sql, institution, case_id, operator_kind, int64_t{limit}),
                  SessionRowFrom<PgColumns>);
  });
}

StoreResult<int64_t> PgStore::CountSessions() {
  return Query<int64_t>("count sessions", [&](pqxx::transaction_base& tx) {
    return StoreResult<int64_t>(tx.exec("SELECT COUNT(*) FROM sessions")[0][0].as<int64_t>());
  });
}

}  // namespace ves::patient_db
