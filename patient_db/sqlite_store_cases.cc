// SqliteStore: cases (content-addressed blobs, versions, shares).
#include <cstdint>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "patient_db/sqlite_store.h"
#include "patient_db/sqlite_store_internal.h"
#include "patient_db/store_rows.h"

namespace ves::patient_db {

StoreResult<std::vector<std::string>> SqliteStore::ReadShares(SqliteDb& db,
                                                              const std::string& case_id,
                                                              uint32_t version) {
  return ReadRows(
      db, "read shares",
      "SELECT institution FROM case_shares WHERE case_id = ? AND version = ? "
      "ORDER BY institution",
      [](const SqliteStatement& s) { return s.Text(0); }, case_id, int64_t{version});
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
  const std::string name = CaseVersionName(row);
  std::optional<CaseRow> existing;
  auto found = ReadFirst(
      db, "put case", "",
      std::string("SELECT ") + kCaseColumns + " FROM cases c WHERE c.case_id = ? AND c.version = ?",
      CaseRowFrom<SqliteStatement>, row.case_id, int64_t{row.version});
  if (found.ok()) {
    existing = std::move(found.value);
  } else if (found.status.code != StoreCode::kNotFound) {
    return fail(found.status);
  }
  if (existing) {
    auto shares = ReadShares(db, row.case_id, row.version);
    if (!shares.ok()) return fail(shares.status);
    existing->shared_with = shares.value;
  }
  const CasePutPlan plan = PlanCasePut(existing ? &*existing : nullptr, row, payload.size());
  if (!plan.status.ok()) return fail(plan.status);
  if (existing && plan.new_shares.empty()) {
    db.Exec("ROLLBACK", nullptr);
    return plan.result;
  }
  if (!existing) {
    StoreStatus st = WriteCase(row, payload);
    if (!st.ok()) return fail(st);
  }
  for (const std::string& institution : plan.new_shares) {
    int rc = SQLITE_OK;
    if (!Execute(db, "INSERT INTO case_shares (case_id, version, institution) VALUES (?, ?, ?)",
                 &rc, row.case_id, int64_t{row.version}, institution)) {
      return fail(Internal(db, "put case share"));
    }
  }
  if (!db.Exec("COMMIT", &error)) {
    return fail(StoreStatus::Error(StoreCode::kInternal, "commit " + name + ": " + error));
  }
  return plan.result;
}

StoreStatus SqliteStore::WriteCase(const CaseRow& row, const std::string& payload) {
  SqliteDb& db = *writer_;
  SqliteStatement* s = db.Prepare(
      "INSERT INTO case_blobs (sha256_hex, size_bytes, payload) VALUES (?, ?, ?) "
      "ON CONFLICT (sha256_hex) DO NOTHING",
      nullptr);
  if (!s) return Internal(db, "put case blob");
  s->Bind(1, row.sha256_hex).Bind(2, static_cast<int64_t>(payload.size())).BindBlob(3, payload);
  int rc = SQLITE_OK;
  if (!Run(s, &rc)) return Internal(db, "put case blob");
  if (Execute(db,
              "INSERT INTO cases (case_id, version, title, difficulty, region_mask, institution, "
              "sha256_hex, payload_sha256_hex, size_bytes, uploaded_by, stored_unix_ms) "
              "VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)",
              &rc, row.case_id, int64_t{row.version}, row.title, int64_t{row.difficulty},
              static_cast<int64_t>(row.region_mask), row.institution, row.sha256_hex,
              row.payload_sha256_hex, static_cast<int64_t>(payload.size()), row.uploaded_by,
              row.stored_unix_ms)) {
    return StoreStatus::Ok();
  }
  const std::string name = CaseVersionName(row);
  if (IsConstraint(rc)) {
    return StoreStatus::Error(StoreCode::kInvalidArgument,
                              name + ": unknown institution '" + row.institution + "'");
  }
  return Internal(db, "put " + name);
}

StoreResult<std::vector<CaseRow>> SqliteStore::ListCases(const CaseFilter& f) {
  std::string sql = std::string("SELECT ") + kCaseColumns + " FROM cases c WHERE 1 = 1";
  if (f.region != 0) sql += " AND (c.region_mask & ?) <> 0";
  if (f.difficulty != 0) sql += " AND c.difficulty = ?";
  if (!f.institution.empty()) sql += " AND c.institution = ?";
  if (!f.visible_to.empty()) {
    sql +=
        " AND (c.institution = ? OR EXISTS (SELECT 1 FROM case_shares s WHERE "
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
    CaseRow row = CaseRowFrom(*s);
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
  if (s->Step(&rc)) row = CaseRowFrom(*s);
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
  return ReadFirst(
      r.db(), "get blob", "no blob " + sha256_hex,
      "SELECT payload FROM case_blobs WHERE sha256_hex = ?",
      [](const SqliteStatement& s) { return s.Blob(0); }, sha256_hex);
}

}  // namespace ves::patient_db
