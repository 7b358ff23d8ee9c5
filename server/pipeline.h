#pragma once

#include <google/protobuf/message.h>
#include <grpcpp/grpcpp.h>

#include <functional>
#include <memory>
#include <mutex>
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
// through the functions below (server/pipeline.cc), so that a rule cannot be
// forgotten in one transport. Transports only translate: gRPC metadata or an
// HTTP header / cookie in, grpc::Status and the response message out. A
// unary call is AdmitRequest then RunCall (ServeUnary); a call that ends
// after its handler returns (a stream, an upload acknowledged once durable)
// is admitted the same way and runs RunCallAsync (ServeAsync for streams).
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

// The authentication stage of AdmitRequest, on its own: the principal from an
// "authorization" value (UNAUTHENTICATED when missing or unknown). For a
// stream, whose messages are bounded as they arrive. Not audited.
grpc::Status AuthenticateCall(const ServiceDeps& deps, std::string_view authorization,
                              Principal* who);

// Role, then `body` (institution rules and the store), then the audit row
// for `target` through the group commit. Returns the call's status.
grpc::Status RunCall(const ServiceDeps& deps, const Principal& who, const CallSpec& spec,
                     const std::string& target, const std::function<grpc::Status()>& body);

// The bounds stage of AdmitRequest, on its own: INVALID_ARGUMENT naming the
// first field of `message` over its limit (patient_db/limits.h), else OK. The
// one check of a message's size and characters for both transports and for
// every message of a stream (AsyncCall::AdmitMessage). The HTTP server's body
// cap (http_server.cc) is only its transport's byte cap, as gRPC's
// --max-message-mb is.
// `path` names the message in the answer ("request.trainee.display_name").
grpc::Status CheckMessageBounds(const google::protobuf::Message& message,
                                const std::string& path = "request");

// A call that ends after its handler returns: a stream (Cases.UploadCase,
// Live.StreamSession) or an upload acknowledged once durable
// (Sessions.UploadSession). Made only by RunCallAsync, after the role stage;
// ending it writes its audit row, so a handler cannot skip the audit: Finish
// audits (as CallSpec says) and hands the status to the transport; a call
// dropped unfinished is audited as CANCELLED when its last reference goes.
class AsyncCall {
 public:
  using Finisher = std::function<void(const grpc::Status&)>;
  AsyncCall(const ServiceDeps& deps, Principal who, const CallSpec& spec, std::string target);
  ~AsyncCall();
  AsyncCall(const AsyncCall&) = delete;
  AsyncCall& operator=(const AsyncCall&) = delete;

  const Principal& who() const { return who_; }
  // What the audit row names; a stream learns it from its first message.
  void set_target(std::string target);
  // How the transport ends the call (a reactor's Finish). Set before
  // anything can call Finish.
  void set_finisher(Finisher finisher);
  // The bounds stage (CheckMessageBounds) for one more message of the call.
  grpc::Status AdmitMessage(const google::protobuf::Message& message,
                            const std::string& path = "request") const;
  // The audit row for an ending written in the caller's own transaction
  // (SessionWriter::Submit writes it with the session and fills in its
  // result); Finish then only finishes.
  patient_db::AuditRow TakeAuditRow();
  // Writes the call's one audit row now, for a call whose row tells how it
  // began (a live stream, audited at its first frame); Finish then only
  // finishes. Only the first audit counts.
  void Audit(const grpc::Status& status);
  // Audits `status` unless the call was audited already, then finishes. Only
  // the first call counts.
  void Finish(const grpc::Status& status);

 private:

  ServiceDeps deps_;
  Principal who_;
  CallSpec spec_;
  std::mutex mutex_;
  std::string target_;      // guarded by mutex_
  Finisher finisher_;       // guarded by mutex_
  bool audited_ = false;    // guarded by mutex_
  bool finished_ = false;   // guarded by mutex_
};

// The async form of RunCall. Role first: a refusal is audited and returned,
// and `body` does not run. Otherwise `body` gets the call, which it (or what
// it starts) must Finish, and RunCallAsync returns OK. Admission (bounds,
// token) comes before, as for RunCall: AdmitRequest or ServeAsync.
grpc::Status RunCallAsync(const ServiceDeps& deps, const Principal& who, const CallSpec& spec,
                          const std::string& target,
                          const std::function<void(std::shared_ptr<AsyncCall>)>& body);

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

// A gRPC streaming handler's pipeline: authenticate from the call's metadata
// (a stream has no message yet: each is bounded as it arrives, by
// AsyncCall::AdmitMessage), then RunCallAsync. `start` makes the reactor that
// serves the admitted call; a refused call gets `refuse(status)`, a reactor
// that only finishes with that status.
template <class Reactor, class Start, class Refuse>
Reactor* ServeAsync(grpc::CallbackServerContext* ctx, const ServiceDeps& deps, const CallSpec& spec,
                    const std::string& target, Start start, Refuse refuse) {
  Principal who;
  grpc::Status admitted = AuthenticateCall(deps, AuthorizationOf(ctx), &who);
  if (!admitted.ok()) return refuse(admitted);
  Reactor* reactor = nullptr;
  const auto body = [&](std::shared_ptr<AsyncCall> call) { reactor = start(std::move(call)); };
  admitted = RunCallAsync(deps, who, spec, target, body);
  return admitted.ok() ? reactor : refuse(admitted);
}

}  // namespace ves::server
