// The live proctoring routes of the HTTP API (docs/web.md, "Live"): the list
// of live sessions and the WebSocket a viewer watches one through.
#include <nlohmann/json.hpp>

#include "patient_db/limits.h"
#include "server/live_hub.h"
#include "server/pipeline.h"
#include "server/web_reply.h"
#include "server/web_routes.h"

namespace ves::server {

using grpc::Status;
using grpc::StatusCode;
using nlohmann::json;

namespace {

json LiveSessionJson(const LiveSessionInfo& l, int64_t now_unix_ms) {
  return {{"session_uuid", l.session_uuid},
          {"institution", l.institution},
          {"trainee_id", l.trainee_id},
          {"case_id", l.case_id},
          {"case_version", l.case_version},
          {"station", l.station},
          {"started_unix_ms", l.started_unix_ms},
          {"last_frame_unix_ms", l.last_frame_unix_ms},
          {"frames", l.frames},
          {"station_dropped", l.station_dropped},
          {"t_s", l.t_s},
          {"remote", !l.origin_replica.empty()},
          {"now_unix_ms", now_unix_ms}};
}

// GET live: the live sessions of the caller's institution (an admin's: all,
// or the one asked for).
HttpReply ListLive(WebCall& call) {
  const std::string institution = call.Query("institution");
  v1::ListTraineesRequest req;  // bounds of the institution filter
  req.set_institution(institution);
  Status s = call.Admit(req);
  if (!s.ok()) return ErrorOf(s);
  static const CallSpec spec{"live.list", kSupervisors, "list live sessions",
                             /*audit_every_call=*/false};
  const Principal& who = call.who;
  std::vector<LiveSessionInfo> live;
  s = RunCall(call.deps, who, spec, institution.empty() ? who.institution : institution,
              [&]() -> Status {
                const std::string scope = institution.empty() && who.role != StoreRole::kAdmin
                                              ? who.institution
                                              : institution;
                if (!scope.empty()) {
                  AuthStatus a = RequireInstitution(who, scope, "list live sessions");
                  if (!a.ok()) return ToGrpcStatus(a);
                }
                if (call.deps.live != nullptr) live = call.deps.live->List(scope);
                return Status::OK;
              });
  if (!s.ok()) return ErrorOf(s);
  json out = json::array();
  const int64_t now = NowUnixMs();
  for (const LiveSessionInfo& l : live) out.push_back(LiveSessionJson(l, now));
  return JsonReply(200, {{"live", out}});
}

// WS live/ws?session=UUID: a viewer of one live session; 101 with the
// viewer in call.live, else the refusal.
HttpReply WatchLive(WebCall& call) {
  const HttpRequest& request = call.request;
  // A page of another origin may open a WebSocket with our cookie where
  // SameSite does not hold (old browsers): the origin must be our own.
  if (!request.origin.empty() && request.origin != "http://" + request.host &&
      request.origin != "https://" + request.host) {
    return Error(
        403, "PERMISSION_DENIED",
        "Origin '" + patient_db::PrintableExcerpt(request.origin, 80) + "': not this server's");
  }
  const std::string uuid = call.Query("session");
  if (uuid.empty()) return Error(400, "INVALID_ARGUMENT", "query: session=UUID missing");
  v1::GetSessionRequest bounds;  // the uuid's bounds, as for a stored session
  bounds.set_uuid(uuid);
  Status s = call.Admit(bounds);
  if (!s.ok()) return ErrorOf(s);
  static const CallSpec spec{"live.watch", kSupervisors, "watch live sessions"};
  std::shared_ptr<LiveViewer> viewer;
  s = RunCall(call.deps, call.who, spec, uuid, [&]() -> Status {
    LiveSessionInfo info;
    if (call.deps.live == nullptr || !call.deps.live->Find(uuid, &info)) {
      return Status(StatusCode::NOT_FOUND, "session " + uuid + " is not live");
    }
    AuthStatus a = RequireInstitution(call.who, info.institution, "watch");
    if (!a.ok()) return ToGrpcStatus(a);
    std::string why;
    viewer = call.deps.live->Watch(uuid, &why);
    if (!viewer) return Status(StatusCode::RESOURCE_EXHAUSTED, why);
    return Status::OK;
  });
  if (!s.ok()) return ErrorOf(s);
  if (call.live != nullptr) {
    call.live->session_uuid = uuid;
    call.live->viewer = std::move(viewer);
  }
  HttpReply ok;
  ok.status = 101;
  return ok;
}

}  // namespace

std::vector<WebRoute> LiveRoutes() {
  return {{"GET", "/api/v1/live", kSupervisors, &ListLive},
          {"WS", "/api/v1/live/ws", kSupervisors, &WatchLive}};
}

}  // namespace ves::server
