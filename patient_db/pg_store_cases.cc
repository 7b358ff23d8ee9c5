// PgStore: cases (content-addressed blobs, versions, shares).
// Races between replicas are settled by the primary keys with INSERT ... ON
// CONFLICT DO NOTHING: the loser waits for the winner's transaction and then
// reads its row, so no error reaches the caller.
#include <optional>
#include <pqxx/pqxx>
#include <string>
#include <utility>
#include <vector>

#include "patient_db/pg_store.h"
#include "patient_db/pg_store_internal.h"
#include "patient_db/store_rows.h"

namespace ves::patient_db {

StoreStatus PgStore::ReadShares(pqxx::transaction_base& tx, CaseRow* row) {
  pqxx::result r = tx.exec_params(
      "SELECT institution FROM case_shares WHERE case_id = $1 AND version = $2 "
      "ORDER BY institution COLLATE \"C\"",
      row->case_id, int64_t{row->version});
  row->shared_with.clear();
  for (const auto& s : r) row->shared_with.push_back(s[0].as<std::string>());
  return StoreStatus::Ok();
}

StoreResult<PutCaseResult> PgStore::PutCase(const CaseRow& row, const std::string& payload) {
  const std::string name = CaseVersionName(row);
  PutCaseResult result;
  StoreStatus st = Transact("put " + name, TxMode::kWrite, [&](pqxx::transaction_base& tx) {
    tx.exec_params(
        "INSERT INTO case_blobs (sha256_hex, size_bytes, payload) VALUES ($1, $2, $3) "
        "ON CONFLICT (sha256_hex) DO NOTHING",
        row.sha256_hex, static_cast<int64_t>(payload.size()), pqxx::binarystring(payload));
    pqxx::result inserted = tx.exec_params(
        "INSERT INTO cases (case_id, version, title, difficulty, region_mask, institution, "
        "sha256_hex, payload_sha256_hex, size_bytes, uploaded_by, stored_unix_ms) "
        "VALUES ($1, $2, $3, $4, $5, $6, $7, $8, $9, $10, $11) "
        "ON CONFLICT (case_id, version) DO NOTHING RETURNING 1",
        row.case_id, int64_t{row.version}, row.title, int64_t{row.difficulty},
        static_cast<int64_t>(row.region_mask), row.institution, row.sha256_hex,
        row.payload_sha256_hex, static_cast<int64_t>(payload.size()), row.uploaded_by,
        row.stored_unix_ms);
    // Not inserted: stored before (maybe a moment ago by another replica).
    // Same content is an idempotent repeat, other content a refusal; the
    // refusal rolls back the blob too.
    std::optional<CaseRow> existing;
    if (inserted.empty()) {
      pqxx::result r = tx.exec_params(std::string("SELECT ") + kCaseColumns +
                                          " FROM cases c WHERE c.case_id = $1 AND c.version = $2",
                                      row.case_id, int64_t{row.version});
      existing = CaseRowFrom(PgColumns(r.at(0)));
      ReadShares(tx, &*existing);
    }
    CasePutPlan plan = PlanCasePut(existing ? &*existing : nullptr, row, payload.size());
    if (!plan.status.ok()) return plan.status;
    // Another replica adding the same share at once is no conflict.
    for (const std::string& institution : plan.new_shares) {
      tx.exec_params(
          "INSERT INTO case_shares (case_id, version, institution) VALUES ($1, $2, $3) "
          "ON CONFLICT DO NOTHING",
          row.case_id, int64_t{row.version}, institution);
    }
    result = std::move(plan.result);
    return StoreStatus::Ok();
  });
  if (st.code == StoreCode::kInvalidArgument) {
    return StoreStatus::Error(StoreCode::kInvalidArgument,
                              name + ": unknown institution '" + row.institution + "'");
  }
  if (!st.ok()) return st;
  return result;
}

StoreResult<std::vector<CaseRow>> PgStore::ListCases(const CaseFilter& f) {
  std::string sql = std::string("SELECT ") + kCaseColumns + " FROM cases c WHERE TRUE";
  // Unused filters compare with themselves so the parameter list stays fixed.
  sql += " AND ($1::BIGINT = 0 OR (c.region_mask & $1::BIGINT) <> 0)";
  sql += " AND ($2::INTEGER = 0 OR c.difficulty = $2::INTEGER)";
  sql += " AND ($3 = '' OR c.institution = $3)";
  sql +=
      " AND ($4 = '' OR c.institution = $4 OR EXISTS (SELECT 1 FROM case_shares s WHERE "
      "s.case_id = c.case_id AND s.version = c.version AND s.institution = $4))";
  // Pages: after (case_id, version) with all versions, else after case_id.
  sql += f.all_versions ? " AND ($5 = 0 OR c.case_id COLLATE \"C\" > $6 OR "
                          "(c.case_id = $6 AND c.version > $7::BIGINT))"
                        : " AND ($5 = 0 OR c.case_id COLLATE \"C\" > $6 OR $7::BIGINT < 0)";
  sql += " ORDER BY c.case_id COLLATE \"C\", c.version";
  const int64_t region_bit = f.region != 0 ? static_cast<int64_t>(uint64_t{1} << f.region) : 0;
  const size_t limit = f.page.limit > 0 ? static_cast<size_t>(f.page.limit) : SIZE_MAX;
  std::vector<CaseRow> out;
  StoreStatus st = Transact("list cases", TxMode::kRead, [&](pqxx::transaction_base& tx) {
    out.clear();
    pqxx::result r =
        tx.exec_params(sql, region_bit, int64_t{f.difficulty}, f.institution, f.visible_to,
                       f.page.has_after ? 1 : 0, f.page.after_text, f.page.after_number);
    for (const auto& row : r) {
      CaseRow c = CaseRowFrom(PgColumns(row));
      // Rows come ordered by (id, version): a later version replaces the last one.
      if (!f.all_versions && !out.empty() && out.back().case_id == c.case_id) {
        out.back() = std::move(c);
        continue;
      }
      if (out.size() == limit) break;  // the next case would be one too many
      out.push_back(std::move(c));
    }
    for (CaseRow& c : out) ReadShares(tx, &c);
    return StoreStatus::Ok();
  });
  if (!st.ok()) return st;
  return out;
}

StoreResult<CaseRow> PgStore::GetCase(const std::string& case_id, uint32_t version) {
  std::string sql = std::string("SELECT ") + kCaseColumns + " FROM cases c WHERE c.case_id = $1";
  sql +=
      version == 0 ? " AND $2::BIGINT = 0 ORDER BY c.version DESC LIMIT 1" : " AND c.version = $2";
  return Query<CaseRow>("get case", [&](pqxx::transaction_base& tx) -> StoreResult<CaseRow> {
    pqxx::result r = tx.exec_params(sql, case_id, int64_t{version});
    if (r.empty()) {
      return StoreStatus::Error(
          StoreCode::kNotFound,
          "no case '" + case_id + "'" +
              (version == 0 ? std::string() : " version " + std::to_string(version)));
    }
    CaseRow out = CaseRowFrom(PgColumns(r[0]));
    ReadShares(tx, &out);
    return out;
  });
}

StoreResult<std::string> PgStore::GetBlob(const std::string& sha256_hex) {
  return Query<std::string>(
      "get blob", [&](pqxx::transaction_base& tx) -> StoreResult<std::string> {
        pqxx::result r =
            tx.exec_params("SELECT payload FROM case_blobs WHERE sha256_hex = $1", sha256_hex);
        if (r.empty()) return StoreStatus::Error(StoreCode::kNotFound, "no blob " + sha256_hex);
        return pqxx::binarystring(r[0][0]).str();
      });
}

}  // namespace ves::patient_db
