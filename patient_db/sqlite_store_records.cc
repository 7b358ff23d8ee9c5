// SqliteStore: cases (content-addressed blobs, versions, shares) and sessions
// (group-committed batches).
#include <algorithm>
#include <map>
#include <optional>
#include <tuple>

#include <cstdint>

#include "patient_db/sqlite_store.h"

namespace ves::patient_db {
namespace {

StoreStatus Internal(SqliteDb& db, const std::string& what) {
  return StoreStatus::Error(StoreCode::kInternal, what + ": " + db.LastError());
}

constexpr const char* kCaseColumns =
    "c.case_id, c.version, c.title, c.difficulty, c.region_mask, c.institution, c.sha256_hex, "
    "c.payload_sha256_hex, c.size_bytes, c.uploaded_by, c.stored_unix_ms";

CaseRow ReadCaseRow(const SqliteStatement& s) {
  CaseRow c;
  c.case_id = s.Text(0);
  c.version = static_cast<uint32_t>(s.Int(1));
  c.title = s.Text(2);
  c.difficulty = static_cast<int>(s.Int(3));
  c.region_mask = static_cast<uint64_t>(s.Int(4));
  c.institution = s.Text(5);
  c.sha256_hex = s.Text(6);
  c.payload_sha256_hex = s.Text(7);
  c.size_bytes = static_cast<uint64_t>(s.Int(8));
  c.uploaded_by = s.Text(9);
  c.stored_unix_ms = s.Int(10);
  return c;
}

constexpr const char* kSessionColumns =
    "uuid, trainee_id, institution, case_id, case_version, station_id, start_unix_ms, "
    "end_unix_ms, outcome, completed, time_to_cecum_s, pain_s, score, body_sha256_hex, "
    "stored_unix_ms, operator_kind, max_tip_arc_m, loop_s, xray_s";

// Column 19 of a session read back: the lesson the record names ('' when
// none), kept in lesson_sessions rather than in sessions.
constexpr const char* kSessionLessonColumn =
    ", COALESCE((SELECT l.lesson_id FROM lesson_sessions l WHERE l.session_uuid = sessions.uuid), "
    "'')";

SessionRow ReadSessionRow(const SqliteStatement& s) {
  SessionRow r;
  r.uuid = s.Text(0);
  r.trainee_id = s.Text(1);
  r.institution = s.Text(2);
  r.case_id = s.Text(3);
  r.case_version = static_cast<uint32_t>(s.Int(4));
  r.station_id = s.Text(5);
  r.start_unix_ms = s.Int(6);
  r.end_unix_ms = s.Int(7);
  r.outcome = static_cast<int>(s.Int(8));
  r.completed = s.Int(9) != 0;
  r.time_to_cecum_s = s.Real(10);
  r.pain_s = s.Real(11);
  r.score = s.Real(12);
  r.body_sha256_hex = s.Text(13);
  r.stored_unix_ms = s.Int(14);
  r.operator_kind = s.Text(15);
  r.max_tip_arc_m = s.Real(16);
  r.loop_s = s.Real(17);
  r.xray_s = s.Real(18);
  return r;
}

constexpr const char* kStationColumns =
    "institution, station_id, last_seen_unix_ms, software_version, version_session_end_unix_ms, "
    "has_health, health_session_uuid, health_session_end_unix_ms, device, loop_cycles, "
    "loop_cycle_p99_us, loop_budget_us, loop_overruns, safe_state_entries, force_pauses, "
    "can_bus_errors, can_lost_frames, can_send_failures, can_malformed_frames";
constexpr int kStationColumnCount = 19;

StationRow ReadStationRow(const SqliteStatement& s) {
  StationRow r;
  r.institution = s.Text(0);
  r.station_id = s.Text(1);
  r.last_seen_unix_ms = s.Int(2);
  r.software_version = s.Text(3);
  r.version_session_end_unix_ms = s.Int(4);
  r.has_health = s.Int(5) != 0;
  r.health_session_uuid = s.Text(6);
  r.health_session_end_unix_ms = s.Int(7);
  StationHealthRow& h = r.health;
  h.device = s.Text(8);
  h.loop_cycles = static_cast<uint64_t>(s.Int(9));
  h.loop_cycle_p99_us = s.Real(10);
  h.loop_budget_us = s.Real(11);
  h.loop_overruns = static_cast<uint64_t>(s.Int(12));
  h.safe_state_entries = static_cast<uint64_t>(s.Int(13));
  h.force_pauses = static_cast<uint64_t>(s.Int(14));
  h.can_bus_errors = static_cast<uint64_t>(s.Int(15));
  h.can_lost_frames = static_cast<uint64_t>(s.Int(16));
  h.can_send_failures = static_cast<uint64_t>(s.Int(17));
  h.can_malformed_frames = static_cast<uint64_t>(s.Int(18));
  return r;
}

void BindStationRow(SqliteStatement* s, const StationRow& r) {
  const StationHealthRow& h = r.health;
  const auto u = [](uint64_t v) { return static_cast<int64_t>(v); };  // bounded by the server
  s->Bind(1, r.institution).Bind(2, r.station_id).Bind(3, r.last_seen_unix_ms);
  s->Bind(4, r.software_version).Bind(5, r.version_session_end_unix_ms);
  s->Bind(6, int64_t{r.has_health}).Bind(7, r.health_session_uuid);
  s->Bind(8, r.health_session_end_unix_ms).Bind(9, h.device).Bind(10, u(h.loop_cycles));
  s->Bind(11, h.loop_cycle_p99_us).Bind(12, h.loop_budget_us).Bind(13, u(h.loop_overruns));
  s->Bind(14, u(h.safe_state_entries)).Bind(15, u(h.force_pauses));
  s->Bind(16, u(h.can_bus_errors)).Bind(17, u(h.can_lost_frames));
  s->Bind(18, u(h.can_send_failures)).Bind(19, u(h.can_malformed_frames));
}

// Runs `s` (already bound) to completion; false on error.
bool Run(SqliteStatement* s, int* rc) {
  *rc = SQLITE_OK;
  s->Step(rc);
  s->Reset();
  return *rc == SQLITE_OK;
}

}  // namespace

StoreResult<std::vector<std::string>> SqliteStore::ReadShares(SqliteDb& db,
                                                              const std::string& case_id,
                                                              uint32_t version) {
  SqliteStatement* s = db.Prepare(
      "SELECT institution FROM case_shares WHERE case_id = ? AND version = ? "
      "ORDER BY institution",
      nullptr);
  if (!s) return Internal(db, "read shares");
  s->Bind(1, case_id).Bind(2, int64_t{version});
  int rc = SQLITE_OK;
  std::vector<std::string> out;
  while (s->Step(&rc)) out.push_back(s->Text(0));
  s->Reset();
  if (rc != SQLITE_OK) return Internal(db, "read shares");
  return out;
}

StoreResult<PutCaseResult> SqliteStore::PutCase(const CaseRow& row, const std::string& payload) {
  std::lock_guard lock(write_mutex_);
  SqliteDb& db = *writer_;
  std::string error;
  if (!db.Exec("BEGIN IMMEDIATE", &error)) {
    return StoreStatus::Error(StoreCode::kInternal, "put case: " + error);
  }
  auto fail = [&](StoreStatus status) {
    db.Exec("ROLLBACK", nullptr);
    return status;
  };
  const std::string name = "case '" + row.case_id + "' version " + std::to_string(row.version);
  SqliteStatement* s = db.Prepare(std::string("SELECT ") + kCaseColumns +
                                      " FROM cases c WHERE c.case_id = ? AND c.version = ?",
                                  nullptr);
  if (!s) return fail(Internal(db, "put case"));
  s->Bind(1, row.case_id).Bind(2, int64_t{row.version});
  int rc = SQLITE_OK;
  std::optional<CaseRow> existing;
  if (s->Step(&rc)) existing = ReadCaseRow(*s);
  s->Reset();
  if (rc != SQLITE_OK) return fail(Internal(db, "put case"));
  if (existing) {
    if (existing->sha256_hex != row.sha256_hex) {
      return fail(StoreStatus::Error(
          StoreCode::kAlreadyExists,
          name + " is already stored with other content (sha256 " + existing->sha256_hex +
              "); give the new content a higher version"));
    }
    auto shares = ReadShares(db, row.case_id, row.version);
    if (!shares.ok()) return fail(shares.status);
    existing->shared_with = shares.value;
    std::string refusal;
    const std::vector<std::string> added =
        NewCaseShares(*existing, row.institution, row.shared_with, &refusal);
    if (!refusal.empty()) return fail(StoreStatus::Error(StoreCode::kAlreadyExists, refusal));
    if (added.empty()) {
      db.Exec("ROLLBACK", nullptr);
      return PutCaseResult{*existing, true};
    }
    for (const std::string& institution : added) {
      s = db.Prepare("INSERT INTO case_shares (case_id, version, institution) VALUES (?, ?, ?)",
                     nullptr);
      if (!s) return fail(Internal(db, "put case share"));
      s->Bind(1, row.case_id).Bind(2, int64_t{row.version}).Bind(3, institution);
      if (!Run(s, &rc)) return fail(Internal(db, "put case share"));
      existing->shared_with.push_back(institution);
    }
    std::sort(existing->shared_with.begin(), existing->shared_with.end());
    if (!db.Exec("COMMIT", &error)) {
      return fail(StoreStatus::Error(StoreCode::kInternal, "commit " + name + ": " + error));
    }
    return PutCaseResult{*existing, true};
  }
  s = db.Prepare(
      "INSERT INTO case_blobs (sha256_hex, size_bytes, payload) VALUES (?, ?, ?) "
      "ON CONFLICT (sha256_hex) DO NOTHING",
      nullptr);
  if (!s) return fail(Internal(db, "put case blob"));
  s->Bind(1, row.sha256_hex).Bind(2, static_cast<int64_t>(payload.size())).BindBlob(3, payload);
  if (!Run(s, &rc)) return fail(Internal(db, "put case blob"));
  s = db.Prepare(
      "INSERT INTO cases (case_id, version, title, difficulty, region_mask, institution, "
      "sha256_hex, payload_sha256_hex, size_bytes, uploaded_by, stored_unix_ms) "
      "VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)",
      nullptr);
  if (!s) return fail(Internal(db, "put case"));
  s->Bind(1, row.case_id).Bind(2, int64_t{row.version}).Bind(3, row.title);
  s->Bind(4, int64_t{row.difficulty}).Bind(5, static_cast<int64_t>(row.region_mask));
  s->Bind(6, row.institution).Bind(7, row.sha256_hex).Bind(8, row.payload_sha256_hex);
  s->Bind(9, static_cast<int64_t>(payload.size())).Bind(10, row.uploaded_by);
  s->Bind(11, row.stored_unix_ms);
  if (!Run(s, &rc)) {
    if ((rc & 0xff) == SQLITE_CONSTRAINT) {
      return fail(StoreStatus::Error(StoreCode::kInvalidArgument,
                                     name + ": unknown institution '" + row.institution + "'"));
    }
    return fail(Internal(db, "put " + name));
  }
  CaseRow stored = row;
  stored.size_bytes = payload.size();
  std::map<std::string, bool> shares;  // sorted, unique
  for (const std::string& i : row.shared_with) {
    if (i != row.institution) shares[i] = true;
  }
  stored.shared_with.clear();
  for (const auto& [institution, unused] : shares) {
    s = db.Prepare("INSERT INTO case_shares (case_id, version, institution) VALUES (?, ?, ?)",
                   nullptr);
    if (!s) return fail(Internal(db, "put case share"));
    s->Bind(1, row.case_id).Bind(2, int64_t{row.version}).Bind(3, institution);
    if (!Run(s, &rc)) return fail(Internal(db, "put case share"));
    stored.shared_with.push_back(institution);
  }
  if (!db.Exec("COMMIT", &error)) {
    return fail(StoreStatus::Error(StoreCode::kInternal, "commit " + name + ": " + error));
  }
  return PutCaseResult{stored, false};
}

StoreResult<std::vector<CaseRow>> SqliteStore::ListCases(const CaseFilter& f) {
  std::string sql = std::string("SELECT ") + kCaseColumns + " FROM cases c WHERE 1 = 1";
  if (f.region != 0) sql += " AND (c.region_mask & ?) <> 0";
  if (f.difficulty != 0) sql += " AND c.difficulty = ?";
  if (!f.institution.empty()) sql += " AND c.institution = ?";
  if (!f.visible_to.empty()) {
    sql += " AND (c.institution = ? OR EXISTS (SELECT 1 FROM case_shares s WHERE "
           "s.case_id = c.case_id AND s.version = c.version AND s.institution = ?))";
  }
  if (f.page.has_after) {
    sql += f.all_versions ? " AND (c.case_id > ? OR (c.case_id = ? AND c.version > ?))"
                          : " AND c.case_id > ?";
  }
  sql += " ORDER BY c.case_id, c.version";
  Reader r = Read();
  SqliteStatement* s = r.db().Prepare(sql, nullptr);
  if (!s) return Internal(r.db(), "list cases");
  int i = 1;
  if (f.region != 0) s->Bind(i++, static_cast<int64_t>(uint64_t{1} << f.region));
  if (f.difficulty != 0) s->Bind(i++, int64_t{f.difficulty});
  if (!f.institution.empty()) s->Bind(i++, f.institution);
  if (!f.visible_to.empty()) {
    s->Bind(i, f.visible_to).Bind(i + 1, f.visible_to);
    i += 2;
  }
  if (f.page.has_after) {
    s->Bind(i++, f.page.after_text);
    if (f.all_versions) {
      s->Bind(i, f.page.after_text).Bind(i + 1, f.page.after_number);
      i += 2;
    }
  }
  int rc = SQLITE_OK;
  std::vector<CaseRow> out;
  const size_t limit = f.page.limit > 0 ? static_cast<size_t>(f.page.limit) : SIZE_MAX;
  while (s->Step(&rc)) {
    CaseRow row = ReadCaseRow(*s);
    // Rows come ordered by (id, version): a later version replaces the last one.
    if (!f.all_versions && !out.empty() && out.back().case_id == row.case_id) {
      out.back() = std::move(row);
      continue;
    }
    if (out.size() == limit) break;  // the next case would be one too many
    out.push_back(std::move(row));
  }
  s->Reset();
  if (rc != SQLITE_OK) return Internal(r.db(), "list cases");
  for (CaseRow& row : out) {
    auto shares = ReadShares(r.db(), row.case_id, row.version);
    if (!shares.ok()) return shares.status;
    row.shared_with = std::move(shares.value);
  }
  return out;
}

StoreResult<CaseRow> SqliteStore::GetCase(const std::string& case_id, uint32_t version) {
  Reader r = Read();
  std::string sql = std::string("SELECT ") + kCaseColumns + " FROM cases c WHERE c.case_id = ?";
  sql += version == 0 ? " ORDER BY c.version DESC LIMIT 1" : " AND c.version = ?";
  SqliteStatement* s = r.db().Prepare(sql, nullptr);
  if (!s) return Internal(r.db(), "get case");
  s->Bind(1, case_id);
  if (version != 0) s->Bind(2, int64_t{version});
  int rc = SQLITE_OK;
  std::optional<CaseRow> row;
  if (s->Step(&rc)) row = ReadCaseRow(*s);
  s->Reset();
  if (rc != SQLITE_OK) return Internal(r.db(), "get case");
  if (!row) {
    return StoreStatus::Error(
        StoreCode::kNotFound,
        "no case '" + case_id + "'" +
            (version == 0 ? std::string() : " version " + std::to_string(version)));
  }
  auto shares = ReadShares(r.db(), row->case_id, row->version);
  if (!shares.ok()) return shares.status;
  row->shared_with = std::move(shares.value);
  return *row;
}

StoreResult<std::string> SqliteStore::GetBlob(const std::string& sha256_hex) {
  Reader r = Read();
  SqliteStatement* s =
      r.db().Prepare("SELECT payload FROM case_blobs WHERE sha256_hex = ?", nullptr);
  if (!s) return Internal(r.db(), "get blob");
  s->Bind(1, sha256_hex);
  int rc = SQLITE_OK;
  std::optional<std::string> payload;
  if (s->Step(&rc)) payload = s->Blob(0);
  s->Reset();
  if (rc != SQLITE_OK) return Internal(r.db(), "get blob");
  if (!payload) return StoreStatus::Error(StoreCode::kNotFound, "no blob " + sha256_hex);
  return std::move(*payload);
}

StoreStatus SqliteStore::WriteSession(const SessionRow& row, SessionPutResult* result) {
  SqliteDb& db = *writer_;
  SqliteStatement* s = db.Prepare(
      std::string("SELECT ") + kSessionColumns + " FROM sessions WHERE uuid = ?", nullptr);
  if (!s) return Internal(db, "find session");
  s->Bind(1, row.uuid);
  int rc = SQLITE_OK;
  std::optional<SessionRow> first;
  if (s->Step(&rc)) first = ReadSessionRow(*s);
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
  if (s->Step(&rc)) stored = ReadStationRow(*s);
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
  SqliteStatement* s =
      r.db().Prepare(std::string("SELECT ") + kStationColumns +
                         " FROM stations WHERE institution = ? AND (? = 0 OR station_id > ?) "
                         "ORDER BY station_id LIMIT ?",
                     nullptr);
  if (!s) return Internal(r.db(), "list stations");
  s->Bind(1, institution).Bind(2, int64_t{page.has_after}).Bind(3, page.after_text);
  s->Bind(4, int64_t{page.limit > 0 ? page.limit : -1});
  int rc = SQLITE_OK;
  std::vector<StationRow> out;
  while (s->Step(&rc)) out.push_back(ReadStationRow(*s));
  s->Reset();
  if (rc != SQLITE_OK) return Internal(r.db(), "list stations");
  return out;
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
  SqliteStatement* s =
      r.db().Prepare(std::string("SELECT ") + kSessionColumns + kSessionLessonColumn +
                         ", body FROM sessions WHERE uuid = ?",
                     nullptr);
  if (!s) return Internal(r.db(), "get session");
  s->Bind(1, uuid);
  int rc = SQLITE_OK;
  std::optional<SessionRow> row;
  if (s->Step(&rc)) {
    row = ReadSessionRow(*s);
    row->lesson_id = s->Text(19);
    row->body = s->Blob(20);
  }
  s->Reset();
  if (rc != SQLITE_OK) return Internal(r.db(), "get session");
  if (!row) return StoreStatus::Error(StoreCode::kNotFound, "no session '" + uuid + "'");
  return std::move(*row);
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
  while (s->Step(&rc)) {
    out.push_back(ReadSessionRow(*s));
    out.back().lesson_id = s->Text(19);
  }
  s->Reset();
  if (rc != SQLITE_OK) return Internal(r.db(), "list sessions");
  return out;
}

StoreResult<std::vector<std::vector<SessionRow>>> SqliteStore::ListSessionsOf(
    const std::vector<std::string>& trainee_ids, int64_t from_unix_ms, int64_t to_unix_ms,
    int limit_each) {
  Reader r = Read();
  SqliteStatement* s = r.db().Prepare(
      std::string("SELECT ") + kSessionColumns + kSessionLessonColumn +
          " FROM sessions WHERE trainee_id IN (SELECT value FROM json_each(?))"
          " AND start_unix_ms >= ? AND (? = 0 OR start_unix_ms < ?)",
      nullptr);
  if (!s) return Internal(r.db(), "list sessions of trainees");
  s->Bind(1, JsonStringArray(trainee_ids))
      .Bind(2, from_unix_ms)
      .Bind(3, to_unix_ms)
      .Bind(4, to_unix_ms);
  int rc = SQLITE_OK;
  std::map<std::string, std::vector<SessionRow>> of;
  while (s->Step(&rc)) {
    SessionRow row = ReadSessionRow(*s);
    row.lesson_id = s->Text(19);
    of[row.trainee_id].push_back(std::move(row));
  }
  s->Reset();
  if (rc != SQLITE_OK) return Internal(r.db(), "list sessions of trainees");
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
  SqliteStatement* s = r.db().Prepare(
      "SELECT trainee_id, COUNT(*), MAX(end_unix_ms) FROM sessions "
      "WHERE trainee_id IN (SELECT value FROM json_each(?)) GROUP BY trainee_id",
      nullptr);
  if (!s) return Internal(r.db(), "trainee activity");
  s->Bind(1, JsonStringArray(trainee_ids));
  int rc = SQLITE_OK;
  std::map<std::string, TraineeActivity> of;
  while (s->Step(&rc)) of[s->Text(0)] = {s->Int(1), s->Int(2)};
  s->Reset();
  if (rc != SQLITE_OK) return Internal(r.db(), "trainee activity");
  return InKeyOrder(trainee_ids, std::move(of));
}

StoreResult<std::vector<SessionRow>> SqliteStore::ListOperatorSessions(
    const std::string& institution, const std::string& case_id, const std::string& operator_kind,
    int limit) {
  Reader r = Read();
  SqliteStatement* s = r.db().Prepare(
      std::string("SELECT ") + kSessionColumns +
          " FROM sessions WHERE institution = ? AND case_id = ? AND operator_kind = ?"
          " ORDER BY start_unix_ms DESC, uuid DESC LIMIT ?",
      nullptr);
  if (!s) return Internal(r.db(), "list operator sessions");
  s->Bind(1, institution).Bind(2, case_id).Bind(3, operator_kind).Bind(4, int64_t{limit});
  int rc = SQLITE_OK;
  std::vector<SessionRow> out;
  while (s->Step(&rc)) out.push_back(ReadSessionRow(*s));
  s->Reset();
  if (rc != SQLITE_OK) return Internal(r.db(), "list operator sessions");
  return out;
}

StoreResult<int64_t> SqliteStore::CountSessions() {
  Reader r = Read();
  SqliteStatement* s = r.db().Prepare("SELECT COUNT(*) FROM sessions", nullptr);
  if (!s) return Internal(r.db(), "count sessions");
  int rc = SQLITE_OK;
  int64_t n = 0;
  if (s->Step(&rc)) n = s->Int(0);
  s->Reset();
  if (rc != SQLITE_OK) return Internal(r.db(), "count sessions");
  return n;
}

}  // namespace ves::patient_db
