// The trainee and session routes of the HTTP API (docs/web.md): who is signed
// in, the trainee list, a trainee's sessions and their CSV export, a session,
// its series and its replay. Each is one call of server/pipeline.h.
#include <google/protobuf/util/json_util.h>

#include <nlohmann/json.hpp>

#include "server/pipeline.h"
#include "server/session_series.h"
#include "server/web_cohort.h"
#include "server/web_reply.h"
#include "server/web_routes.h"

namespace ves::server {

using grpc::Status;
using grpc::StatusCode;
using nlohmann::json;

namespace {

// GET me: the signed-in principal (and the browser session's CSRF token).
HttpReply Me(WebCall& call) {
  Status s = call.Admit(v1::ListTraineesRequest());
  if (!s.ok()) return ErrorOf(s);
  static const CallSpec spec{"web.me", kEveryRole, "read who you are",
                             /*audit_every_call=*/false};
  s = RunCall(call.deps, call.who, spec, "", [] { return Status::OK; });
  if (!s.ok()) return ErrorOf(s);
  json j = {{"role", patient_db::RoleName(call.who.role)},
            {"institution", call.who.institution},
            {"label", call.who.label},
            {"trainee_id", call.who.trainee_id}};
  if (!call.session_id.empty()) {
    const std::string csrf = call.api.CsrfTokenOf(call.session_id);
    if (!csrf.empty()) j["csrf_token"] = csrf;
  }
  return JsonReply(200, j);
}

// POST trainees: Trainees.AddTrainee.
HttpReply AddTrainee(WebCall& call) {
  v1::AddTraineeRequest req;
  if (!google::protobuf::util::JsonStringToMessage(call.request.body, req.mutable_trainee())
           .ok()) {
    return Error(400, "INVALID_ARGUMENT",
                 "body: must be {\"trainee_id\": ..., \"display_name\": ..., "
                 "\"institution\": ...}");
  }
  v1::AddTraineeResponse resp;
  if (auto refused = AdmitAndCall(call, req, &AddTraineeCall, &resp)) return *refused;
  return JsonReply(200, ProtoJson(resp));
}

// GET trainees: the list with groups, last activity and curricula progress.
HttpReply ListTrainees(WebCall& call) {
  v1::ListTraineesRequest req;
  req.set_institution(call.Query("institution"));
  req.set_page_size(static_cast<uint32_t>(call.page_size));
  req.set_page_token(call.Query("page_token"));
  v1::ListTraineesResponse resp;
  if (auto refused = AdmitAndCall(call, req, &ListTraineesCall, &resp)) return *refused;
  // The call admitted reading this institution's trainees: their groups,
  // activity, assignments and verdicts are read for the whole page, one
  // store read each (not per trainee: docs/server.md, "Web pages at scale").
  patient_db::Store& store = *call.deps.store;
  std::vector<std::string> ids;
  for (const auto& t : resp.trainees()) ids.push_back(t.trainee_id());
  auto group_of = store.GetTraineeGroups(ids);
  if (!group_of.ok()) return ErrorOf(ToGrpcStatus(group_of.status));
  auto activity = store.GetTraineeActivity(ids);
  if (!activity.ok()) return ErrorOf(ToGrpcStatus(activity.status));
  auto assignments = store.ListAssignmentsOf(ids);
  if (!assignments.ok()) return ErrorOf(ToGrpcStatus(assignments.status));
  auto verdicts = store.ListLessonVerdictsOf(ids);
  if (!verdicts.ok()) return ErrorOf(ToGrpcStatus(verdicts.status));
  CurriculumCache curricula(&store);
  json trainees = json::array();
  std::map<std::string, std::vector<std::string>> groups;
  for (int i = 0; i < resp.trainees_size(); ++i) {
    const auto& t = resp.trainees(i);
    json row = ProtoJson(t);
    const std::string& group = group_of.value[i];
    row["group"] = group;
    if (!group.empty()) groups[group].push_back(t.trainee_id());
    row["sessions"] = activity.value[i].sessions;
    row["last_activity_unix_ms"] = activity.value[i].last_end_unix_ms;
    row["curricula"] = CurriculaProgressJson(curricula, assignments.value[i], verdicts.value[i]);
    trainees.push_back(std::move(row));
  }
  json group_list = json::array();
  for (auto& [name, members] : groups) {
    group_list.push_back({{"group", name}, {"trainees", members}});
  }
  return JsonReply(200, {{"trainees", trainees},
                         {"groups", group_list},
                         {"next_page_token", resp.next_page_token()}});
}

// GET trainees/{id}/sessions.csv: the export (docs/web.md, "Export").
HttpReply ExportSessions(WebCall& call) {
  TraineeExport out;
  if (auto refused = ReadTraineeExport(call, &out)) return *refused;
  HttpReply r;
  r.content_type = "text/csv; charset=utf-8";
  r.body = SessionsCsv(out.sessions, out.verdicts);
  r.headers.emplace_back("Content-Disposition", "attachment; filename=\"ves-sessions-" +
                                                    FileNamePart(call.Param("id")) + ".csv\"");
  return r;
}

// GET trainees/{id}/sessions: Trainees.ListSessions.
HttpReply ListSessions(WebCall& call) {
  v1::ListSessionsRequest req;
  req.set_trainee_id(call.Param("id"));
  req.set_case_id(call.Query("case_id"));
  req.set_page_size(static_cast<uint32_t>(call.page_size));
  req.set_page_token(call.Query("page_token"));
  v1::ListSessionsResponse resp;
  if (auto refused = AdmitAndCall(call, req, &ListSessionsCall, &resp)) return *refused;
  return JsonReply(200, ProtoJson(resp));
}

// GET sessions/{uuid}/series: the page's plots and replay track, computed once.
HttpReply SessionSeriesRoute(WebCall& call) {
  v1::GetSessionRequest req;
  req.set_uuid(call.Param("uuid"));
  Status s = call.Admit(req);
  if (!s.ok()) return ErrorOf(s);
  HttpReply r;
  s = SessionSeriesCall(call.deps, call.who, req, &r.body);
  if (!s.ok()) return ErrorOf(s);
  return r;
}

// GET sessions/{uuid}: the record without its input log, with the station's
// health shaped as on the stations page and the lesson verdict.
HttpReply GetSession(WebCall& call) {
  v1::GetSessionRequest req;
  req.set_uuid(call.Param("uuid"));
  v1::GetSessionResponse resp;
  if (auto refused = AdmitAndCall(call, req, &GetSessionCall, &resp)) return *refused;
  v1::SessionRecord summary = resp.record();
  summary.clear_input_log();  // bulky and of no use to a reader
  summary.clear_replay_setup();
  // Numbers, not the proto's uint64 strings.
  const bool has_health = resp.record().has_station_health();
  return JsonReply(
      200,
      {{"record", ProtoJson(summary)},
       {"stored_unix_ms", resp.stored_unix_ms()},
       {"input_samples", resp.record().input_log().sample_count()},
       {"station_health",
        has_health ? StationHealthJson(resp.record().station_health()) : json(nullptr)},
       {"station_health_flags",
        has_health ? json(StationHealthFlags(resp.record().station_health())) : json::array()},
       {"lesson_verdict", LessonVerdictJson(*call.deps.store, resp.record())}});
}

json ReplayFramesJson(const SessionReplay& replay) {
  json frames = json::array();
  for (const ReplayFrame& f : replay.frames) {
    json j = {{"t_s", f.t_s},
              {"base_force_N", f.base_force_N},
              {"stretch_m", f.stretch_m},
              {"tip_arc_m", f.tip_arc_m},
              {"inserted_m", f.inserted_m},
              {"pain", f.pain},
              {"loop", f.loop}};
    if (!f.scope_mm.empty()) j["scope_mm"] = f.scope_mm;
    if (!f.colon_mm.empty()) j["colon_mm"] = f.colon_mm;
    frames.push_back(std::move(j));
  }
  return frames;
}

// GET sessions/{uuid}/replay: the model re-run from the stored input log.
HttpReply ReplaySessionRoute(WebCall& call) {
  v1::GetSessionRequest req;
  req.set_uuid(call.Param("uuid"));
  Status s = call.Admit(req);
  if (!s.ok()) return ErrorOf(s);
  static const CallSpec spec{"session.replay", kReaders, "replay sessions"};
  std::shared_ptr<const SessionReplay> replay;
  s = RunCall(call.deps, call.who, spec, req.uuid(), [&]() -> Status {
    // The read rules of GetSession (its own audit row names the read).
    v1::GetSessionResponse resp;
    Status read = GetSessionCall(call.deps, call.who, req, &resp);
    if (!read.ok()) return read;
    try {
      replay = call.api.CachedReplay(req.uuid(), resp.record());
    } catch (const std::exception& e) {
      return Status(StatusCode::FAILED_PRECONDITION,
                    "session " + req.uuid() + " cannot be replayed: " + e.what());
    }
    if (!replay) {
      return Status(StatusCode::RESOURCE_EXHAUSTED,
                    std::to_string(kMaxConcurrentReplays) +
                        " replays are running; ask again in a few seconds");
    }
    return Status::OK;
  });
  if (!s.ok()) return ErrorOf(s);
  return JsonReply(200, {{"uuid", req.uuid()},
                         {"pain_stretch_m", replay->pain_stretch_m},
                         {"cecum_arc_m", replay->cecum_arc_m},
                         {"final_tip_arc_m", replay->final_tip_arc_m},
                         {"summary", replay->summary_line},
                         {"frames", ReplayFramesJson(*replay)}});
}

}  // namespace

std::optional<HttpReply> ReadTraineeExport(WebCall& call, TraineeExport* out) {
  const std::string& id = call.Param("id");
  HttpReply bad;
  if (!QueryTimeRange(call.query, &out->from_unix_ms, &out->to_unix_ms, &bad)) return bad;
  v1::ListSessionsRequest req;  // the trainee id's bounds
  req.set_trainee_id(id);
  Status s = call.Admit(req);
  if (s.ok()) {
    s = ExportSessionsCall(call.deps, call.who, id, out->from_unix_ms, out->to_unix_ms,
                           &out->sessions, &out->verdicts);
  }
  if (!s.ok()) return ErrorOf(s);
  return std::nullopt;
}

std::vector<WebRoute> RecordRoutes() {
  const std::vector<patient_db::StoreRole> list_trainees = {
      patient_db::StoreRole::kAdmin, patient_db::StoreRole::kSupervisor,
      patient_db::StoreRole::kStation};
  return {{"GET", "/api/v1/me", kEveryRole, &Me},
          {"GET", "/api/v1/trainees", list_trainees, &ListTrainees},
          {"POST", "/api/v1/trainees", kSupervisors, &AddTrainee},
          {"GET", "/api/v1/trainees/{id}/sessions", kReaders, &ListSessions},
          {"GET", "/api/v1/trainees/{id}/sessions.csv", kReaders, &ExportSessions},
          {"GET", "/api/v1/sessions/{uuid}", kReaders, &GetSession},
          {"GET", "/api/v1/sessions/{uuid}/series", kReaders, &SessionSeriesRoute},
          {"GET", "/api/v1/sessions/{uuid}/replay", kReaders, &ReplaySessionRoute}};
}

}  // namespace ves::server
