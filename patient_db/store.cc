#include "patient_db/store.h"

#include <algorithm>
#include <nlohmann/json.hpp>
#include <stdexcept>

#include "patient_db/limits.h"
#include "patient_db/sqlite_store.h"

namespace ves::patient_db {

const char* RoleName(StoreRole role) {
  switch (role) {
    case StoreRole::kAdmin: return "admin";
    case StoreRole::kSupervisor: return "supervisor";
    case StoreRole::kStation: return "station";
    case StoreRole::kTrainee: return "trainee";
  }
  return "unknown";
}

bool ParseRoleName(const std::string& name, StoreRole* role) {
  for (StoreRole r : {StoreRole::kAdmin, StoreRole::kSupervisor, StoreRole::kStation,
                      StoreRole::kTrainee}) {
    if (name == RoleName(r)) {
      *role = r;
      return true;
    }
  }
  return false;
}

const char* SessionPutAuditResult(SessionPut outcome) {
  switch (outcome) {
    case SessionPut::kStored: return "OK";
    case SessionPut::kDuplicate: return "OK duplicate";
    case SessionPut::kConflict: return "ALREADY_EXISTS";
  }
  return "UNKNOWN";
}

StationRow MergeStationReport(const StationRow* stored, const StationRow& report) {
  if (stored == nullptr) return report;
  StationRow out = *stored;
  out.last_seen_unix_ms = std::max(stored->last_seen_unix_ms, report.last_seen_unix_ms);
  if (report.version_session_end_unix_ms >= stored->version_session_end_unix_ms) {
    out.software_version = report.software_version;
    out.version_session_end_unix_ms = report.version_session_end_unix_ms;
  }
  if (report.has_health && (!stored->has_health || report.health_session_end_unix_ms >=
                                                       stored->health_session_end_unix_ms)) {
    out.has_health = true;
    out.health = report.health;
    out.health_session_uuid = report.health_session_uuid;
    out.health_session_end_unix_ms = report.health_session_end_unix_ms;
  }
  return out;
}

std::string JsonStringArray(const std::vector<std::string>& ids) {
  // replace: an id that is not UTF-8 cannot throw here; it then matches no row.
  return nlohmann::json(ids).dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
}

std::vector<std::string> NewCaseShares(const CaseRow& stored, const std::string& requested_owner,
                                       const std::vector<std::string>& requested,
                                       std::string* refusal) {
  refusal->clear();
  std::vector<std::string> added;
  for (const std::string& i : requested) {
    if (i == stored.institution || std::find(stored.shared_with.begin(), stored.shared_with.end(),
                                             i) != stored.shared_with.end()) {
      continue;
    }
    added.push_back(i);
  }
  std::sort(added.begin(), added.end());
  added.erase(std::unique(added.begin(), added.end()), added.end());
  if (!added.empty() && requested_owner != stored.institution) {
    *refusal = CaseVersionName(stored) + " is owned by institution '" + stored.institution +
               "': only its owner can share it (upload it again for that institution)";
    return {};
  }
  return added;
}

std::string CaseVersionName(const CaseRow& row) {
  return "case '" + row.case_id + "' version " + std::to_string(row.version);
}

CasePutPlan PlanCasePut(const CaseRow* stored, const CaseRow& row, uint64_t size_bytes) {
  CasePutPlan plan;
  if (stored == nullptr) {
    plan.new_shares = row.shared_with;
    std::sort(plan.new_shares.begin(), plan.new_shares.end());
    plan.new_shares.erase(std::unique(plan.new_shares.begin(), plan.new_shares.end()),
                          plan.new_shares.end());
    plan.new_shares.erase(
        std::remove(plan.new_shares.begin(), plan.new_shares.end(), row.institution),
        plan.new_shares.end());
    plan.result.row = row;
    plan.result.row.size_bytes = size_bytes;
    plan.result.row.shared_with = plan.new_shares;
    return plan;
  }
  if (stored->sha256_hex != row.sha256_hex) {
    plan.status =
        StoreStatus::Error(StoreCode::kAlreadyExists,
                           CaseVersionName(row) + " is already stored with other content (sha256 " +
                               stored->sha256_hex + "); give the new content a higher version");
    return plan;
  }
  std::string refusal;
  plan.new_shares = NewCaseShares(*stored, row.institution, row.shared_with, &refusal);
  if (!refusal.empty()) {
    plan.status = StoreStatus::Error(StoreCode::kAlreadyExists, refusal);
    return plan;
  }
  plan.result = {*stored, /*already_stored=*/true};
  std::vector<std::string>& shares = plan.result.row.shared_with;
  shares.insert(shares.end(), plan.new_shares.begin(), plan.new_shares.end());
  std::sort(shares.begin(), shares.end());
  return plan;
}

std::unique_ptr<Store> OpenStore(const std::string& url) {
  const std::string kSqlite = "sqlite:";
  if (url.rfind(kSqlite, 0) == 0 && url.size() > kSqlite.size()) {
    return std::make_unique<SqliteStore>(url.substr(kSqlite.size()));
  }
  throw std::invalid_argument("unknown database URL '" + url +
                              "' (expected sqlite:PATH; postgresql comes later)");
}

StoreStatus CheckSessionSeries(const SessionSeriesRow& row) {
  if (row.session_uuid.empty()) {
    return StoreStatus::Error(StoreCode::kInvalidArgument, "session series: no session uuid");
  }
  if (row.json.empty() || row.json.size() > kMaxSessionSeriesBytes) {
    return StoreStatus::Error(StoreCode::kInvalidArgument,
                              "session series of '" + row.session_uuid +
                                  "': " + std::to_string(row.json.size()) + " bytes, not 1.." +
                                  std::to_string(kMaxSessionSeriesBytes));
  }
  return StoreStatus::Ok();
}

StoreStatus CheckSessionNote(const SessionNoteRow& row) {
  if (row.note_id.empty() || row.session_uuid.empty()) {
    return StoreStatus::Error(StoreCode::kInvalidArgument, "session note: no note id or session");
  }
  if (row.text.empty() || row.text.size() > kMaxSessionNoteBytes) {
    return StoreStatus::Error(StoreCode::kInvalidArgument,
                              "note text: " + std::to_string(row.text.size()) + " bytes, not 1.." +
                                  std::to_string(kMaxSessionNoteBytes));
  }
  if (!IsPrintableText(row.text, /*allow_newlines=*/true)) {
    return StoreStatus::Error(StoreCode::kInvalidArgument,
                              "note text: must be printable UTF-8 (newlines allowed)");
  }
  return StoreStatus::Ok();
}

}  // namespace ves::patient_db
