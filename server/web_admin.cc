// The administration routes of the HTTP API (docs/web.md, "Stations",
// "Audit log"): the stations' last uploads and health, the audit log.
#include <nlohmann/json.hpp>

#include "patient_db/limits.h"
#include "server/pipeline.h"
#include "server/session_check.h"
#include "server/web_reply.h"
#include "server/web_routes.h"

namespace ves::server {

using grpc::Status;
using grpc::StatusCode;
using nlohmann::json;

namespace {

// GET stations: last seen, version and health as their uploads reported them.
HttpReply ListStations(WebCall& call) {
  v1::ListStationsRequest req;
  req.set_institution(call.Query("institution"));
  req.set_page_size(static_cast<uint32_t>(call.page_size));
  req.set_page_token(call.Query("page_token"));
  v1::ListStationsResponse resp;
  if (auto refused = AdmitAndCall(call, req, &ListStationsCall, &resp)) return *refused;
  json stations = json::array();
  for (const auto& st : resp.stations()) {
    json row = {{"station_id", st.station_id()},
                {"institution", st.institution()},
                {"last_seen_unix_ms", st.last_seen_unix_ms()},
                {"software_version", st.software_version()},
                {"health", nullptr},
                {"flags", json::array()}};
    if (st.has_health()) {
      json health = StationHealthJson(st.health());
      health["session_uuid"] = st.health_session_uuid();
      health["session_end_unix_ms"] = st.health_session_end_unix_ms();
      row["health"] = std::move(health);
      row["flags"] = StationHealthFlags(st.health());
    }
    stations.push_back(std::move(row));
  }
  return JsonReply(200, {{"stations", stations},
                         {"next_page_token", resp.next_page_token()},
                         {"now_unix_ms", NowUnixMs()}});
}

// The audit page's filters from the query (actor, action, time range) and its
// page size; false with a 400 naming the parameter.
bool ReadAuditQuery(const WebCall& call, patient_db::AuditQuery* q, uint64_t* limit,
                    HttpReply* bad) {
  uint64_t from = 0, to = 0;
  if (!QueryNumber(call.query, "from_unix_ms", INT64_MAX, &from, bad)) return false;
  if (!QueryNumber(call.query, "since_unix_ms", INT64_MAX, &from, bad)) return false;  // older name
  if (!QueryNumber(call.query, "to_unix_ms", INT64_MAX, &to, bad)) return false;
  if (!QueryNumber(call.query, "limit", patient_db::kMaxPageSize, limit, bad)) return false;
  if (call.page_size > 0) *limit = call.page_size;
  for (const auto& [name, field] : {std::pair{"actor", &q->actor}, {"action", &q->action}}) {
    *field = call.Query(name);
    if (!field->empty() && !patient_db::IsPrintableId(*field)) {
      *bad = Error(400, "INVALID_ARGUMENT",
                   std::string("query ") + name + " = '" +
                       patient_db::PrintableExcerpt(*field, 40) + "': must be 1.." +
                       std::to_string(patient_db::kMaxIdBytes) + " printable characters");
      return false;
    }
  }
  if (to != 0 && to <= from) {
    *bad = Error(400, "INVALID_ARGUMENT",
                 "query to_unix_ms = " + std::to_string(to) +
                     ": must be after from_unix_ms = " + std::to_string(from));
    return false;
  }
  q->from_unix_ms = static_cast<int64_t>(from);
  q->to_unix_ms = static_cast<int64_t>(to);
  return true;
}

json AuditEntryJson(const patient_db::AuditRow& r) {
  StoreRole role = StoreRole::kTrainee;
  return {{"id", r.id},
          {"at_unix_ms", r.at_unix_ms},
          {"actor", r.actor},
          {"actor_label", r.actor_label},
          {"role", patient_db::ParseRoleName(r.role, &role) ? v1::Role_Name(ToProtoRole(role))
                                                            : "ROLE_UNSPECIFIED"},
          {"institution", r.institution},
          {"action", r.action},
          {"target", r.target},
          {"result", r.result}};
}

// GET audit: newest first, filtered by actor, action and time, paged.
HttpReply ListAudit(WebCall& call) {
  const std::string page_token = call.Query("page_token");
  v1::ListAuditRequest req;  // the page token's bounds
  req.set_page_token(page_token);
  patient_db::AuditQuery q;
  uint64_t limit = 0;
  HttpReply bad;
  if (!ReadAuditQuery(call, &q, &limit, &bad)) return bad;
  Status s = call.Admit(req);
  if (!s.ok()) return ErrorOf(s);
  // The rules of Admin.ListAudit: admins only, reading it is not audited
  // (every page would write to it), refusals are.
  static const CallSpec spec{"audit.list", kAdmins, "read the audit log",
                             /*audit_every_call=*/false};
  std::vector<patient_db::AuditRow> rows;
  std::string next;
  s = RunCall(call.deps, call.who, spec, "", [&]() -> Status {
    const int size = PageSizeOf(static_cast<uint32_t>(limit), patient_db::kDefaultPageSize);
    patient_db::ListPage after;
    Status token = ReadPageToken(page_token, "audit-newest", &after);
    if (!token.ok()) return token;
    q.before_id = after.has_after ? after.after_number : 0;
    q.limit = size + 1;
    auto listed = call.deps.store->ListAuditNewest(q);
    if (!listed.ok()) return ToGrpcStatus(listed.status);
    rows = std::move(listed.value);
    if (static_cast<int>(rows.size()) > size) {
      rows.resize(size);
      next = MakePageToken("audit-newest", rows.back().id, "");
    }
    return Status::OK;
  });
  if (!s.ok()) return ErrorOf(s);
  json entries = json::array();
  for (const auto& r : rows) entries.push_back(AuditEntryJson(r));
  return JsonReply(200, {{"entries", entries}, {"next_page_token", next}});
}

}  // namespace

std::vector<WebRoute> AdminRoutes() {
  return {{"GET", "/api/v1/stations", kSupervisors, &ListStations},
          {"GET", "/api/v1/audit", kAdmins, &ListAudit}};
}

nlohmann::json StationHealthJson(const v1::StationHealth& h) {
  const bool timed = h.loop_cycles() > 0;  // headless runs have no loop timing
  json health = {{"device", h.device()},
                 {"loop_cycle_p99_us", timed ? json(h.loop_cycle_p99_us()) : json(nullptr)},
                 {"loop_budget_us", h.loop_budget_us()}};
  for (const auto& [name, get] : kStationHealthCounts) health[name] = (h.*get)();
  return health;
}

std::vector<std::string> StationHealthFlags(const v1::StationHealth& h) {
  std::vector<std::string> flags;
  if (h.loop_cycles() > 0 && h.loop_cycle_p99_us() > h.loop_budget_us()) {
    flags.push_back("loop_p99");
  }
  if (h.loop_overruns() > 0) flags.push_back("overruns");
  if (h.hard_faults() + h.transient_faults() > 0) flags.push_back("safe_state");
  if (h.can_bus_errors() + h.can_lost_frames() + h.can_send_failures() + h.can_malformed_frames() >
      0) {
    flags.push_back("can_errors");
  }
  return flags;
}

}  // namespace ves::server
