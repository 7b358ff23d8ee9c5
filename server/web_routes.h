#pragma once

#include <google/protobuf/message.h>
#include <grpcpp/grpcpp.h>

#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "server/auth.h"
#include "server/services.h"
#include "server/web_api.h"
#include "server/web_reply.h"

// The HTTP routes of ves-server as one table (docs/web.md, "Routes"): each
// row a method, a path pattern, the roles the pipeline lets through and the
// handler. WebApi::Handle matches a request against the table and hands the
// handler a WebCall; a handler admits its request message through
// WebCall::Admit (pipeline.h AdmitRequest, then the browser's CSRF token) and
// runs its call through RunCall (role, body, audit).
namespace ves::server {

// What a WebSocket route hands over to the connection.
struct LiveWatchSlot {
  std::string session_uuid;
  std::shared_ptr<LiveViewer> viewer;
};

// One request on its way through a route.
struct WebCall {
  WebCall(WebApi& api, const ServiceDeps& deps, const HttpRequest& request)
      : api(api), deps(deps), request(request) {}

  WebApi& api;
  const ServiceDeps& deps;
  const HttpRequest& request;
  std::map<std::string, std::string> params;  // the pattern's {name}s, %-decoded
  std::map<std::string, std::string> query;   // the query string, %-decoded
  std::string authorization;  // "Bearer ..." from the header or the browser session
  bool csrf_ok = true;        // a state change from a browser carried its CSRF token
  std::string session_id;     // the browser session ("" for Bearer calls)
  uint64_t page_size = 0;     // query page_size (0: absent)
  LiveWatchSlot* live = nullptr;  // set for WebSocket upgrades
  Principal who;                  // set by Admit
  bool admitted = false;          // Admit was called (the route went through the pipeline)

  // Bounds of `bounds`, then authentication (pipeline.h AdmitRequest), then
  // the CSRF token of a state-changing request from a browser (403).
  grpc::Status Admit(const google::protobuf::Message& bounds);
  // A pattern parameter ("id" of "trainees/{id}/sessions").
  const std::string& Param(const std::string& name) const;
  // A query parameter; "" when absent.
  std::string Query(const std::string& name) const;
};

using WebHandler = HttpReply (*)(WebCall& call);

struct WebRoute {
  // "GET", "POST", or "WS": a GET with Upgrade: websocket (a GET outside
  // /api/ also answers HEAD).
  const char* method;
  const char* pattern;  // "/api/v1/trainees/{id}/sessions": {name} matches one path segment
  // Who may make the call (RunCall's role stage); empty: a public route
  // (health, pages, signing in), which authenticates nobody.
  std::vector<patient_db::StoreRole> roles;
  WebHandler handler;
};

// Every HTTP route, in the order they are matched.
const std::vector<WebRoute>& WebRoutes();

// The route table's parts, one per file of handlers.
std::vector<WebRoute> SignInRoutes();    // web_sign_in.cc
std::vector<WebRoute> RecordRoutes();    // web_records.cc
std::vector<WebRoute> CurveRoutes();     // web_curve.cc
std::vector<WebRoute> AdminRoutes();     // web_admin.cc
std::vector<WebRoute> LiveRoutes();      // web_live.cc
std::vector<WebRoute> CohortRoutes();    // web_cohort.cc
std::vector<WebRoute> WorkflowRoutes();  // web_workflow.cc

// Roles in one place for the table's rows.
inline const std::vector<patient_db::StoreRole> kEveryRole = {
    patient_db::StoreRole::kAdmin, patient_db::StoreRole::kSupervisor,
    patient_db::StoreRole::kStation, patient_db::StoreRole::kTrainee};
inline const std::vector<patient_db::StoreRole> kReaders = {
    patient_db::StoreRole::kAdmin, patient_db::StoreRole::kSupervisor,
    patient_db::StoreRole::kTrainee};
inline const std::vector<patient_db::StoreRole> kSupervisors = {
    patient_db::StoreRole::kAdmin, patient_db::StoreRole::kSupervisor};
inline const std::vector<patient_db::StoreRole> kAdmins = {patient_db::StoreRole::kAdmin};

// Admits `request` (WebCall::Admit), then runs it through `fn`, one of the
// calls of server/pipeline.h: nullopt with *response filled, else the
// refusal as the reply.
template <class Request, class Response>
std::optional<HttpReply> AdmitAndCall(WebCall& call, const Request& request,
                                      grpc::Status (*fn)(const ServiceDeps&, const Principal&,
                                                         const Request&, Response*),
                                      Response* response) {
  grpc::Status s = call.Admit(request);
  if (s.ok()) s = fn(call.deps, call.who, request, response);
  if (!s.ok()) return ErrorOf(s);
  return std::nullopt;
}

// A trainee's sessions and lesson verdicts in the query's time range
// (from_unix_ms, to_unix_ms), read by the export's rules and audit row
// (pipeline.h ExportSessionsCall) for trainees/{id}/sessions.csv and
// trainees/{id}/report.
struct TraineeExport {
  int64_t from_unix_ms = 0, to_unix_ms = 0;
  std::vector<patient_db::SessionRow> sessions;
  std::vector<patient_db::LessonVerdictRow> verdicts;
};
// nullopt with *out read, else the refusal (web_records.cc).
std::optional<HttpReply> ReadTraineeExport(WebCall& call, TraineeExport* out);

// Whether `path` (without query) matches `pattern`; fills `params` with the
// raw (still %-encoded) segments of its {name}s.
bool MatchPattern(const std::string& pattern, const std::string& path,
                  std::map<std::string, std::string>* params);

}  // namespace ves::server
