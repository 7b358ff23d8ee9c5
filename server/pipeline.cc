// The request pipeline of server/pipeline.h: admit (bounds, then the token),
// role, body, audit; its async form for streams and uploads acknowledged once
// durable; and the status and audit helpers every handler shares.
#include "server/pipeline.h"

#include "patient_db/limits.h"
#include "server/services.h"

namespace ves::server {

using grpc::Status;
using grpc::StatusCode;
using patient_db::StoreCode;
using patient_db::StoreRole;

Status ToGrpcStatus(const patient_db::StoreStatus& s) {
  switch (s.code) {
    case StoreCode::kOk: return Status::OK;
    case StoreCode::kNotFound: return Status(StatusCode::NOT_FOUND, s.message);
    case StoreCode::kAlreadyExists: return Status(StatusCode::ALREADY_EXISTS, s.message);
    case StoreCode::kInvalidArgument: return Status(StatusCode::INVALID_ARGUMENT, s.message);
    case StoreCode::kInternal: break;
  }
  return Status(StatusCode::INTERNAL, "storage error: " + s.message);
}

Status ToGrpcStatus(const AuthStatus& s) {
  switch (s.code) {
    case AuthCode::kOk: return Status::OK;
    case AuthCode::kUnauthenticated: return Status(StatusCode::UNAUTHENTICATED, s.message);
    case AuthCode::kPermissionDenied: return Status(StatusCode::PERMISSION_DENIED, s.message);
    case AuthCode::kInternal: break;
  }
  return Status(StatusCode::INTERNAL, "authentication failed: " + s.message);
}

const char* StatusCodeName(grpc::StatusCode code) {
  static const char* const kNames[] = {
      "OK",           "CANCELLED",         "UNKNOWN",           "INVALID_ARGUMENT",
      "DEADLINE_EXCEEDED", "NOT_FOUND",    "ALREADY_EXISTS",    "PERMISSION_DENIED",
      "RESOURCE_EXHAUSTED", "FAILED_PRECONDITION", "ABORTED",   "OUT_OF_RANGE",
      "UNIMPLEMENTED", "INTERNAL",         "UNAVAILABLE",       "DATA_LOSS",
      "UNAUTHENTICATED"};
  const int i = static_cast<int>(code);
  return i >= 0 && i <= 16 ? kNames[i] : "UNKNOWN";
}


patient_db::AuditRow MakeAudit(const Principal& who, const std::string& action,
                               const std::string& target, const Status& result) {
  patient_db::AuditRow a;
  a.at_unix_ms = NowUnixMs();
  // Bounded and printable whatever the request held (docs/server.md, "Limits").
  a.actor = who.token_id;
  a.actor_label = patient_db::PrintableExcerpt(who.label, kMaxAuditTextBytes);
  a.role = patient_db::RoleName(who.role);
  a.institution = patient_db::PrintableExcerpt(who.institution, kMaxAuditTextBytes);
  a.action = action;
  a.target = patient_db::PrintableExcerpt(target, kMaxAuditTextBytes);
  a.result = result.ok() ? std::string("OK")
                          : std::string(StatusCodeName(result.error_code())) + ": " +
                                patient_db::PrintableExcerpt(result.error_message(), 200);
  return a;
}

std::string_view AuthorizationOf(grpc::CallbackServerContext* ctx) {
  const auto& md = ctx->client_metadata();
  auto it = md.find("authorization");
  return it == md.end() ? std::string_view()
                        : std::string_view(it->second.data(), it->second.size());
}

Status CheckMessageBounds(const google::protobuf::Message& message, const std::string& path) {
  const std::string problem = patient_db::CheckMessageLimits(message, path);
  if (problem.empty()) return Status::OK;
  return Status(StatusCode::INVALID_ARGUMENT, problem);
}

Status AuthenticateCall(const ServiceDeps& deps, std::string_view authorization, Principal* who) {
  return ToGrpcStatus(deps.auth->Authenticate(authorization, who));
}

Status AdmitRequest(const ServiceDeps& deps, std::string_view authorization,
                    const google::protobuf::Message& request, Principal* who) {
  // Bounded before anything looks at it: no store lookup, no audit row.
  const Status bounds = CheckMessageBounds(request);
  if (!bounds.ok()) return bounds;
  return AuthenticateCall(deps, authorization, who);
}

Status RunCall(const ServiceDeps& deps, const Principal& who, const CallSpec& spec,
               const std::string& target, const std::function<Status()>& body) {
  const AuthStatus role = RequireRole(who, spec.roles, spec.what);
  const Status status = role.ok() ? body() : ToGrpcStatus(role);
  if (spec.audit_every_call || !role.ok()) {
    deps.writer->SubmitAudit(MakeAudit(who, spec.action, target, status));
  }
  return status;
}

// ---- The async form ----------------------------------------------------------

AsyncCall::AsyncCall(const ServiceDeps& deps, Principal who, const CallSpec& spec,
                     std::string target)
    : deps_(deps), who_(std::move(who)), spec_(spec), target_(std::move(target)) {}

AsyncCall::~AsyncCall() {
  if (!finished_ && !audited_) {
    deps_.writer->SubmitAudit(MakeAudit(
        who_, spec_.action, target_, Status(StatusCode::CANCELLED, "the call ended unfinished")));
  }
}

void AsyncCall::set_target(std::string target) {
  std::lock_guard lock(mutex_);
  target_ = std::move(target);
}

void AsyncCall::set_finisher(Finisher finisher) {
  std::lock_guard lock(mutex_);
  finisher_ = std::move(finisher);
}

Status AsyncCall::AdmitMessage(const google::protobuf::Message& message,
                               const std::string& path) const {
  return CheckMessageBounds(message, path);
}

patient_db::AuditRow AsyncCall::TakeAuditRow() {
  std::lock_guard lock(mutex_);
  audited_ = true;
  return MakeAudit(who_, spec_.action, target_, Status::OK);
}

void AsyncCall::Audit(const Status& status) {
  std::lock_guard lock(mutex_);
  if (audited_) return;
  audited_ = true;
  // As RunCall: past the role stage, only calls audited on every call.
  if (spec_.audit_every_call) {
    deps_.writer->SubmitAudit(MakeAudit(who_, spec_.action, target_, status));
  }
}

void AsyncCall::Finish(const Status& status) {
  Audit(status);
  Finisher finisher;
  {
    std::lock_guard lock(mutex_);
    if (finished_) return;
    finished_ = true;
    finisher = std::move(finisher_);
  }
  // Last: finishing may end the reactor that holds this call.
  if (finisher) finisher(status);
}

Status RunCallAsync(const ServiceDeps& deps, const Principal& who, const CallSpec& spec,
                    const std::string& target,
                    const std::function<void(std::shared_ptr<AsyncCall>)>& body) {
  const AuthStatus role = RequireRole(who, spec.roles, spec.what);
  if (!role.ok()) {
    const Status refused = ToGrpcStatus(role);
    deps.writer->SubmitAudit(MakeAudit(who, spec.action, target, refused));
    return refused;
  }
  body(std::make_shared<AsyncCall>(deps, who, spec, target));
  return Status::OK;
}

}  // namespace ves::server
