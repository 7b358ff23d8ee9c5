#pragma once

#include <google/protobuf/message.h>
#include <grpcpp/grpcpp.h>

#include <functional>
#include <string>
#include <string_view>
#include <vector>

#include "server/auth.h"
#include "server/services.h"
#include "ves/v1/services.pb.h"

// The one request pipeline (docs/server.md, "One request pipeline"): every
// call, over gRPC or over the HTTP API (docs/web.md), goes
//   admit (bounds, then authentication) -> role -> body (institution rules,
//   store) -> audit
// through the functions below, so that a rule cannot be forgotten in one
// transport. Transports only translate: gRPC metadata or an HTTP header /
// cookie in, grpc::Status and the response message out.
namespace ves::server {

struct CallSpec {
  const char* action;            // audit action, e.g. "trainee.list"
  std::vector<StoreRole> roles;  // who may make the call at all
  const char* what;              // names the call in a role refusal: "list trainees"
  // false: only role refusals are audited (reading the audit log would
  // otherwise write to it on every page).
  bool audit_every_call = true;
};

// The "authorization" metadata of a gRPC call ("" when absent).
std::string_view AuthorizationOf(grpc::CallbackServerContext* ctx);

// Bounds first (INVALID_ARGUMENT naming the field; no store lookup), then the
// principal from an "authorization" value ("Bearer <token>"; empty: missing).
// Not audited: there is nobody to name yet.
grpc::Status AdmitRequest(const ServiceDeps& deps, std::string_view authorization,
                          const google::protobuf::Message& request, Principal* who);

// Role, then `body` (institution rules and the store), then the audit row
// for `target` through the group commit. Returns the call's status.
grpc::Status RunCall(const ServiceDeps& deps, const Principal& who, const CallSpec& spec,
                     const std::string& target, const std::function<grpc::Status()>& body);

// The calls served by both transports: each is one RunCall.
grpc::Status AddTraineeCall(const ServiceDeps&, const Principal&, const v1::AddTraineeRequest&,
                            v1::AddTraineeResponse*);
grpc::Status ListTraineesCall(const ServiceDeps&, const Principal&, const v1::ListTraineesRequest&,
                              v1::ListTraineesResponse*);
grpc::Status ListSessionsCall(const ServiceDeps&, const Principal&, const v1::ListSessionsRequest&,
                              v1::ListSessionsResponse*);
grpc::Status GetLearningCurveCall(const ServiceDeps&, const Principal&,
                                  const v1::LearningCurveRequest&, v1::LearningCurveResponse*);
grpc::Status GetSessionCall(const ServiceDeps&, const Principal&, const v1::GetSessionRequest&,
                            v1::GetSessionResponse*);
grpc::Status CreateTokenCall(const ServiceDeps&, const Principal&, const v1::CreateTokenRequest&,
                             v1::CreateTokenResponse*);
grpc::Status ListAuditCall(const ServiceDeps&, const Principal&, const v1::ListAuditRequest&,
                           v1::ListAuditResponse*);
grpc::Status ListStationsCall(const ServiceDeps&, const Principal&, const v1::ListStationsRequest&,
                              v1::ListStationsResponse*);
grpc::Status GetProgressCall(const ServiceDeps&, const Principal&, const v1::GetProgressRequest&,
                             v1::GetProgressResponse*);
grpc::Status ListCurriculaCall(const ServiceDeps&, const Principal&,
                               const v1::ListCurriculaRequest&, v1::ListCurriculaResponse*);
grpc::Status AssignCurriculumCall(const ServiceDeps&, const Principal&,
                                  const v1::AssignCurriculumRequest&,
                                  v1::AssignCurriculumResponse*);
grpc::Status SetTraineeGroupCall(const ServiceDeps&, const Principal&,
                                 const v1::SetTraineeGroupRequest&, v1::SetTraineeGroupResponse*);

// What a CSV export of a trainee's sessions holds (docs/web.md): the sessions
// started in [from_unix_ms, to_unix_ms) (to 0: no bound), oldest first, and
// the trainee's lesson verdicts. The read rules of ListSessions; audited as
// session.export. More than kMaxExportSessions sessions in the range:
// OUT_OF_RANGE (narrow the dates).
inline constexpr int kMaxExportSessions = 20000;
grpc::Status ExportSessionsCall(const ServiceDeps& deps, const Principal& who,
                                const std::string& trainee_id, int64_t from_unix_ms,
                                int64_t to_unix_ms, std::vector<patient_db::SessionRow>* sessions,
                                std::vector<patient_db::LessonVerdictRow>* verdicts);

// A gRPC unary handler over one of the calls above: admit from the call's
// metadata, run, finish.
template <class Request, class Response>
grpc::ServerUnaryReactor* ServeUnary(grpc::CallbackServerContext* ctx, const ServiceDeps& deps,
                                     const Request* request, Response* response,
                                     grpc::Status (*call)(const ServiceDeps&, const Principal&,
                                                          const Request&, Response*)) {
  auto* reactor = ctx->DefaultReactor();
  Principal who;
  grpc::Status admitted = AdmitRequest(deps, AuthorizationOf(ctx), *request, &who);
  reactor->Finish(admitted.ok() ? call(deps, who, *request, response) : admitted);
  return reactor;
}

}  // namespace ves::server
