// Sessions, Trainees and Admin services, and the helpers every handler shares.
#include <google/protobuf/io/coded_stream.h>
#include <google/protobuf/io/zero_copy_stream_impl_lite.h>

#include <algorithm>
#include <charconv>
#include <chrono>
#include <map>

#include "patient_db/limits.h"
#include "server/pipeline.h"
#include "server/services.h"
#include "server/session_check.h"
#include "server/session_series.h"

namespace ves::server {

using grpc::Status;
using grpc::StatusCode;
using patient_db::StoreCode;
using patient_db::StoreRole;

int64_t NowUnixMs() {
  return std::chrono::duration_cast<std::chrono::milliseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

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

ves::v1::Role ToProtoRole(StoreRole role) { return static_cast<ves::v1::Role>(role); }

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

void FinishAudited(grpc::ServerUnaryReactor* reactor, const ServiceDeps& deps,
                   const Principal& who, const std::string& action, const std::string& target,
                   const Status& status) {
  deps.writer->SubmitAudit(MakeAudit(who, action, target, status));
  reactor->Finish(status);
}

Status CheckRequestLimits(const google::protobuf::Message& request) {
  const std::string problem = patient_db::CheckMessageLimits(request, "request");
  if (problem.empty()) return Status::OK;
  return Status(StatusCode::INVALID_ARGUMENT, problem);
}

std::string_view AuthorizationOf(grpc::CallbackServerContext* ctx) {
  const auto& md = ctx->client_metadata();
  auto it = md.find("authorization");
  return it == md.end() ? std::string_view()
                        : std::string_view(it->second.data(), it->second.size());
}

bool Admit(grpc::CallbackServerContext* ctx, grpc::ServerUnaryReactor* reactor,
           const ServiceDeps& deps, const google::protobuf::Message& request, Principal* who) {
  const Status admitted = AdmitRequest(deps, AuthorizationOf(ctx), request, who);
  if (admitted.ok()) return true;
  reactor->Finish(admitted);
  return false;
}

std::string DeterministicBytes(const google::protobuf::Message& m) {
  std::string out;
  {
    google::protobuf::io::StringOutputStream stream(&out);
    google::protobuf::io::CodedOutputStream coded(&stream);
    coded.SetSerializationDeterministic(true);
    m.SerializeToCodedStream(&coded);
  }
  return out;
}

bool IsName(const std::string& s) { return patient_db::IsPrintableId(s); }

int PageSizeOf(uint32_t requested, int default_size) {
  if (requested == 0) return default_size;
  return static_cast<int>(std::min<uint32_t>(requested, patient_db::kMaxPageSize));
}

std::string MakePageToken(const std::string& listing, int64_t number, const std::string& text) {
  return listing + ":" + std::to_string(number) + ":" + text;
}

Status ReadPageToken(const std::string& token, const std::string& listing,
                     patient_db::ListPage* page) {
  if (token.empty()) return Status::OK;
  const auto bad = [&] {
    return Status(StatusCode::INVALID_ARGUMENT,
                  "page_token = '" + patient_db::PrintableExcerpt(token, 40) +
                      "': not a next_page_token of this listing");
  };
  if (token.compare(0, listing.size() + 1, listing + ":") != 0) return bad();
  const size_t number_end = token.find(':', listing.size() + 1);
  if (number_end == std::string::npos) return bad();
  const std::string number = token.substr(listing.size() + 1, number_end - listing.size() - 1);
  int64_t value = 0;
  const auto [end, ec] = std::from_chars(number.data(), number.data() + number.size(), value);
  if (number.empty() || ec != std::errc() || end != number.data() + number.size()) return bad();
  page->has_after = true;
  page->after_number = value;
  page->after_text = token.substr(number_end + 1);
  return Status::OK;
}

namespace {

ves::v1::SessionSummary ToSummary(const patient_db::SessionRow& r) {
  ves::v1::SessionSummary s;
  s.set_uuid(r.uuid);
  s.set_trainee_id(r.trainee_id);
  s.set_case_id(r.case_id);
  s.set_case_version(r.case_version);
  s.set_station_id(r.station_id);
  s.set_start_unix_ms(r.start_unix_ms);
  s.set_end_unix_ms(r.end_unix_ms);
  s.set_outcome(static_cast<ves::v1::Outcome>(r.outcome));
  s.set_completed(r.completed);
  s.set_time_to_cecum_s(r.time_to_cecum_s);
  s.set_pain_s(r.pain_s);
  s.set_score(r.score);
  s.set_operator_kind(r.operator_kind);
  s.set_max_tip_arc_m(r.max_tip_arc_m);
  return s;
}

void ToTrainee(const patient_db::TraineeRow& r, ves::v1::Trainee* t) {
  t->set_trainee_id(r.trainee_id);
  t->set_institution(r.institution);
  t->set_display_name(r.display_name);
  t->set_created_unix_ms(r.created_unix_ms);
}

Status HiddenTrainee(const std::string& id) {
  return Status(StatusCode::NOT_FOUND, "no trainee '" + id + "'");
}

// Looks the trainee up and checks that `who` may read their records.
Status ReadableTrainee(const ServiceDeps& deps, const Principal& who, const std::string& id,
                       const std::string& what, patient_db::TraineeRow* trainee) {
  AuthStatus a = RequireRole(who, {StoreRole::kAdmin, StoreRole::kSupervisor,
                                   StoreRole::kTrainee}, what);
  if (!a.ok()) return ToGrpcStatus(a);
  auto found = deps.store->GetTrainee(id);
  if (!found.ok()) return ToGrpcStatus(found.status);
  // Another institution's trainee (or, for a trainee, anyone else) answers
  // as an absent one does: outside its institution a trainee id's existence
  // is not told.
  if (!RequireTraineeReader(who, found.value, what).ok()) return HiddenTrainee(id);
  *trainee = found.value;
  return Status::OK;
}

void ToStationHealth(const patient_db::StationHealthRow& h, ves::v1::StationHealth* out) {
  out->set_device(h.device);
  out->set_loop_cycles(h.loop_cycles);
  out->set_loop_cycle_p99_us(h.loop_cycle_p99_us);
  out->set_loop_budget_us(h.loop_budget_us);
  out->set_loop_overruns(h.loop_overruns);
  out->set_safe_state_entries(h.safe_state_entries);
  out->set_force_pauses(h.force_pauses);
  out->set_can_bus_errors(h.can_bus_errors);
  out->set_can_lost_frames(h.can_lost_frames);
  out->set_can_send_failures(h.can_send_failures);
  out->set_can_malformed_frames(h.can_malformed_frames);
}

}  // namespace

patient_db::StationRow StationReportOf(const ves::v1::SessionRecord& rec,
                                       const std::string& institution, int64_t now_unix_ms) {
  patient_db::StationRow r;
  r.institution = institution;
  r.station_id = rec.station_id();
  r.last_seen_unix_ms = now_unix_ms;
  r.software_version = rec.software_version();
  r.version_session_end_unix_ms = rec.end_unix_ms();
  if (rec.has_station_health()) {
    const ves::v1::StationHealth& h = rec.station_health();
    r.has_health = true;
    r.health_session_uuid = rec.uuid();
    r.health_session_end_unix_ms = rec.end_unix_ms();
    r.health = {
        h.device(),          h.loop_cycles(),        h.loop_cycle_p99_us(),   h.loop_budget_us(),
        h.loop_overruns(),   h.safe_state_entries(), h.force_pauses(),        h.can_bus_errors(),
        h.can_lost_frames(), h.can_send_failures(),  h.can_malformed_frames()};
  }
  return r;
}

// ---- Sessions --------------------------------------------------------------

patient_db::StoreResult<std::string> SessionsService::TraineeInstitution(
    const std::string& trainee_id) {
  {
    std::lock_guard lock(mutex_);
    auto it = trainee_institution_.find(trainee_id);
    if (it != trainee_institution_.end()) return it->second;
  }
  auto trainee = deps_.store->GetTrainee(trainee_id);
  if (!trainee.ok()) return trainee.status;
  std::lock_guard lock(mutex_);
  trainee_institution_[trainee_id] = trainee.value.institution;
  return trainee.value.institution;
}

Status SessionsService::CheckRecordCase(const ves::v1::SessionRecord& rec,
                                        const std::string& institution) {
  const std::string named = "record.case_id = '" + rec.case_id() + "' version " +
                            std::to_string(rec.case_version());
  auto row = deps_.store->GetCase(rec.case_id(), rec.case_version());
  if (!row.ok() && row.status.code != StoreCode::kNotFound) return ToGrpcStatus(row.status);
  const bool visible = row.ok() && (row.value.institution == institution ||
                                    std::find(row.value.shared_with.begin(),
                                              row.value.shared_with.end(),
                                              institution) != row.value.shared_with.end());
  if (!visible) {
    return Status(StatusCode::FAILED_PRECONDITION,
                  named + ": no such case visible to institution '" + institution + "'");
  }
  if (!rec.case_sha256_hex().empty() && rec.case_sha256_hex() != row.value.payload_sha256_hex) {
    return Status(StatusCode::INVALID_ARGUMENT,
                  "record.case_sha256_hex = " + rec.case_sha256_hex() + ": " + named +
                      " has payload sha256 " + row.value.payload_sha256_hex);
  }
  return Status::OK;
}

grpc::ServerUnaryReactor* SessionsService::UploadSession(
    grpc::CallbackServerContext* ctx, const ves::v1::UploadSessionRequest* request,
    ves::v1::UploadSessionResponse* response) {
  auto* reactor = ctx->DefaultReactor();
  Principal who;
  if (!Admit(ctx, reactor, deps_, *request, &who)) return reactor;
  const ves::v1::SessionRecord& rec = request->record();
  auto reject = [&](const Status& s) {
    FinishAudited(reactor, deps_, who, "session.upload", rec.uuid(), s);
    return reactor;
  };
  AuthStatus a = RequireRole(who, {StoreRole::kAdmin, StoreRole::kStation}, "upload sessions");
  if (!a.ok()) return reject(ToGrpcStatus(a));
  if (!request->has_record()) return reject(Status(StatusCode::INVALID_ARGUMENT, "record missing"));
  const std::string problem = CheckSessionRecord(rec, NowUnixMs());
  if (!problem.empty()) return reject(Status(StatusCode::INVALID_ARGUMENT, problem));
  auto institution = TraineeInstitution(rec.trainee_id());
  // Absent, or of another institution: the same answer (no existence leak).
  if (institution.status.code == StoreCode::kNotFound ||
      (institution.ok() && !RequireInstitution(who, institution.value, "upload").ok())) {
    return reject(Status(StatusCode::FAILED_PRECONDITION,
                         "record.trainee_id = '" + rec.trainee_id() + "': no such trainee in "
                         "institution '" + who.institution + "'"));
  }
  if (!institution.ok()) return reject(ToGrpcStatus(institution.status));
  // The case must exist in the version named and be visible to the trainee's
  // institution; its payload hash, when the record gives one, must match.
  const Status case_status = CheckRecordCase(rec, institution.value);
  if (!case_status.ok()) return reject(case_status);

  patient_db::SessionRow row;
  row.uuid = rec.uuid();
  row.trainee_id = rec.trainee_id();
  row.institution = institution.value;
  row.case_id = rec.case_id();
  row.case_version = rec.case_version();
  row.station_id = rec.station_id();
  row.start_unix_ms = rec.start_unix_ms();
  row.end_unix_ms = rec.end_unix_ms();
  row.outcome = rec.outcome();
  row.completed = rec.metrics().completed();
  row.time_to_cecum_s = rec.metrics().time_to_cecum_s();
  row.pain_s = rec.metrics().pain_s();
  row.score = rec.score();
  row.operator_kind = rec.operator_kind();
  row.max_tip_arc_m = rec.metrics().max_tip_arc_m();
  row.loop_s = rec.metrics().loop_s();
  row.xray_s = rec.metrics().xray_s();
  row.body = DeterministicBytes(rec);
  row.body_sha256_hex = Sha256HexOf(row.body);
  row.stored_unix_ms = NowUnixMs();
  row.lesson_id = rec.lesson_id();  // queued for the lesson judge in the same transaction
  // The station's report, merged into table stations in the same transaction.
  row.station = StationReportOf(rec, institution.value, row.stored_unix_ms);
  const std::string body_sha = row.body_sha256_hex;
  LessonJudge* judge = rec.lesson_id().empty() ? nullptr : deps_.judge;
  SessionSeries* series = deps_.series;
  // Acknowledged from the writer thread once the batch holding it is durable.
  deps_.writer->Submit(
      std::move(row), MakeAudit(who, "session.upload", rec.uuid(), Status::OK),
      [reactor, response, body_sha, judge, series, institution = institution.value](
          const patient_db::StoreStatus& status, const patient_db::SessionPutResult& result) {
        if (!status.ok()) {
          reactor->Finish(ToGrpcStatus(status));
          return;
        }
        if (result.outcome == patient_db::SessionPut::kConflict &&
            result.first.institution != institution) {
          // Another institution's session: nothing about it is told.
          reactor->Finish(Status(StatusCode::ALREADY_EXISTS,
                                 "session " + result.first.uuid +
                                     ": this uuid is taken; a record needs a new uuid"));
          return;
        }
        if (result.outcome == patient_db::SessionPut::kConflict) {
          reactor->Finish(Status(StatusCode::ALREADY_EXISTS,
                                 "session " + result.first.uuid +
                                     " was already uploaded with other content (stored body "
                                     "sha256 " + result.first.body_sha256_hex + ", this one " +
                                     body_sha + "); a changed record needs a new uuid"));
          return;
        }
        if (judge && result.outcome == patient_db::SessionPut::kStored) {
          judge->Enqueue(result.first.uuid);  // durable now; judged off the gRPC threads
        }
        // The session page's plots, computed once: a lesson session's by the
        // judge's replay, a free run's by the series worker.
        if (series && !judge && result.outcome == patient_db::SessionPut::kStored) {
          series->Enqueue(result.first.uuid);
        }
        response->set_uuid(result.first.uuid);
        response->set_body_sha256_hex(result.first.body_sha256_hex);
        response->set_stored_unix_ms(result.first.stored_unix_ms);
        reactor->Finish(Status::OK);
      });
  return reactor;
}

// ---- The pipeline ------------------------------------------------------------

Status AdmitRequest(const ServiceDeps& deps, std::string_view authorization,
                    const google::protobuf::Message& request, Principal* who) {
  // Bounded before anything looks at it: no store lookup, no audit row.
  const Status limits = CheckRequestLimits(request);
  if (!limits.ok()) return limits;
  return ToGrpcStatus(deps.auth->Authenticate(authorization, who));
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

// ---- Trainees --------------------------------------------------------------

Status AddTraineeCall(const ServiceDeps& deps, const Principal& who,
                      const ves::v1::AddTraineeRequest& request,
                      ves::v1::AddTraineeResponse* response) {
  const ves::v1::Trainee& t = request.trainee();
  static const CallSpec spec{
      "trainee.add", {StoreRole::kAdmin, StoreRole::kSupervisor}, "add trainees"};
  return RunCall(deps, who, spec, t.trainee_id(), [&]() -> Status {
    if (!IsName(t.trainee_id())) {
      return Status(StatusCode::INVALID_ARGUMENT,
                    "trainee.trainee_id = '" + t.trainee_id() + "': must be 1..128 printable "
                    "characters");
    }
    patient_db::TraineeRow row{t.trainee_id(),
                               t.institution().empty() ? who.institution : t.institution(),
                               t.display_name(), NowUnixMs()};
    if (!IsName(row.institution)) {
      return Status(StatusCode::INVALID_ARGUMENT,
                    "trainee.institution = '" + row.institution + "': not a valid name");
    }
    // Admins may create an institution here; a supervisor adds to their own.
    AuthStatus a = RequireInstitution(who, row.institution, "add trainees to the institution");
    if (!a.ok()) return ToGrpcStatus(a);
    auto st = deps.store->AddInstitution(row.institution, row.created_unix_ms);
    if (st.ok()) st = deps.store->AddTrainee(row);
    if (!st.ok()) return ToGrpcStatus(st);
    ToTrainee(row, response->mutable_trainee());
    return Status::OK;
  });
}

grpc::ServerUnaryReactor* TraineesService::AddTrainee(grpc::CallbackServerContext* ctx,
                                                      const ves::v1::AddTraineeRequest* request,
                                                      ves::v1::AddTraineeResponse* response) {
  return ServeUnary(ctx, deps_, request, response, &AddTraineeCall);
}

Status ListTraineesCall(const ServiceDeps& deps, const Principal& who,
                        const ves::v1::ListTraineesRequest& request,
                        ves::v1::ListTraineesResponse* response) {
  const std::string institution =
      request.institution().empty() ? who.institution : request.institution();
  static const CallSpec spec{"trainee.list",
                             {StoreRole::kAdmin, StoreRole::kSupervisor, StoreRole::kStation},
                             "list trainees"};
  return RunCall(deps, who, spec, institution, [&]() -> Status {
    AuthStatus a = RequireInstitution(who, institution, "list the trainees");
    if (!a.ok()) return ToGrpcStatus(a);
    patient_db::ListPage page;
    const Status token = ReadPageToken(request.page_token(), "trainees", &page);
    if (!token.ok()) return token;
    const int size = PageSizeOf(request.page_size());
    page.limit = size + 1;  // one more tells whether a next page exists
    auto rows = deps.store->ListTrainees(institution, page);
    if (!rows.ok()) return ToGrpcStatus(rows.status);
    size_t bytes = 0;
    for (int i = 0; i < static_cast<int>(rows.value.size()) && i < size; ++i) {
      ToTrainee(rows.value[i], response->add_trainees());
      bytes += response->trainees(i).ByteSizeLong() + 8;
      const bool more = i + 1 < static_cast<int>(rows.value.size());
      if (more && (i + 1 == size || bytes > kPageReplyBudgetBytes)) {
        response->set_next_page_token(MakePageToken("trainees", 0, rows.value[i].trainee_id));
        break;
      }
    }
    return Status::OK;
  });
}

grpc::ServerUnaryReactor* TraineesService::ListTrainees(grpc::CallbackServerContext* ctx,
                                                        const ves::v1::ListTraineesRequest* request,
                                                        ves::v1::ListTraineesResponse* response) {
  return ServeUnary(ctx, deps_, request, response, &ListTraineesCall);
}

Status ListSessionsCall(const ServiceDeps& deps, const Principal& who,
                        const ves::v1::ListSessionsRequest& request,
                        ves::v1::ListSessionsResponse* response) {
  static const CallSpec spec{"trainee.sessions",
                             {StoreRole::kAdmin, StoreRole::kSupervisor, StoreRole::kTrainee},
                             "list the sessions"};
  return RunCall(deps, who, spec, request.trainee_id(), [&]() -> Status {
    patient_db::TraineeRow trainee;
    Status s = ReadableTrainee(deps, who, request.trainee_id(), "list the sessions", &trainee);
    if (!s.ok()) return s;
    patient_db::ListPage page;
    s = ReadPageToken(request.page_token(), "sessions", &page);
    if (!s.ok()) return s;
    const int size = PageSizeOf(request.page_size());
    page.limit = size + 1;
    auto rows = deps.store->ListSessions(trainee.trainee_id, request.case_id(), page);
    if (!rows.ok()) return ToGrpcStatus(rows.status);
    size_t bytes = 0;
    for (int i = 0; i < static_cast<int>(rows.value.size()) && i < size; ++i) {
      *response->add_sessions() = ToSummary(rows.value[i]);
      bytes += response->sessions(i).ByteSizeLong() + 8;
      const bool more = i + 1 < static_cast<int>(rows.value.size());
      if (more && (i + 1 == size || bytes > kPageReplyBudgetBytes)) {
        const auto& last = rows.value[i];
        response->set_next_page_token(MakePageToken("sessions", last.start_unix_ms, last.uuid));
        break;
      }
    }
    return Status::OK;
  });
}

Status ExportSessionsCall(const ServiceDeps& deps, const Principal& who,
                          const std::string& trainee_id, int64_t from_unix_ms, int64_t to_unix_ms,
                          std::vector<patient_db::SessionRow>* sessions,
                          std::vector<patient_db::LessonVerdictRow>* verdicts) {
  static const CallSpec spec{"session.export",
                             {StoreRole::kAdmin, StoreRole::kSupervisor, StoreRole::kTrainee},
                             "export the sessions"};
  return RunCall(deps, who, spec, trainee_id, [&]() -> Status {
    patient_db::TraineeRow trainee;
    Status s = ReadableTrainee(deps, who, trainee_id, "export the sessions", &trainee);
    if (!s.ok()) return s;
    // From the first session starting at from_unix_ms (the listing's key is
    // (start, uuid) and every uuid sorts after ""), one more than the bound.
    patient_db::ListPage page;
    page.has_after = from_unix_ms > 0;
    page.after_number = from_unix_ms;
    page.limit = kMaxExportSessions + 1;
    auto rows = deps.store->ListSessions(trainee.trainee_id, "", page);
    if (!rows.ok()) return ToGrpcStatus(rows.status);
    sessions->clear();
    for (auto& row : rows.value) {
      if (to_unix_ms > 0 && row.start_unix_ms >= to_unix_ms) break;
      if (static_cast<int>(sessions->size()) == kMaxExportSessions) {
        return Status(StatusCode::OUT_OF_RANGE, "more than " + std::to_string(kMaxExportSessions) +
                                                    " sessions of " + trainee_id +
                                                    " in this range: export fewer days at a time");
      }
      sessions->push_back(std::move(row));
    }
    auto judged = deps.store->ListLessonVerdicts(trainee.trainee_id);
    if (!judged.ok()) return ToGrpcStatus(judged.status);
    *verdicts = std::move(judged.value);
    return Status::OK;
  });
}

grpc::ServerUnaryReactor* TraineesService::ListSessions(grpc::CallbackServerContext* ctx,
                                                        const ves::v1::ListSessionsRequest* request,
                                                        ves::v1::ListSessionsResponse* response) {
  return ServeUnary(ctx, deps_, request, response, &ListSessionsCall);
}

Status GetLearningCurveCall(const ServiceDeps& deps, const Principal& who,
                            const ves::v1::LearningCurveRequest& request,
                            ves::v1::LearningCurveResponse* response) {
  static const CallSpec spec{"trainee.curve",
                             {StoreRole::kAdmin, StoreRole::kSupervisor, StoreRole::kTrainee},
                             "read the learning curve"};
  return RunCall(deps, who, spec, request.trainee_id(), [&]() -> Status {
    patient_db::TraineeRow trainee;
    Status s =
        ReadableTrainee(deps, who, request.trainee_id(), "read the learning curve", &trainee);
    if (!s.ok()) return s;
    auto rows = deps.store->ListSessions(trainee.trainee_id, "");
    if (!rows.ok()) return ToGrpcStatus(rows.status);
    // Sessions come oldest first: attempts are numbered per case in that order.
    std::map<std::string, ves::v1::CaseCurve> curves;
    for (const auto& r : rows.value) {
      ves::v1::CaseCurve& curve = curves[r.case_id];
      curve.set_case_id(r.case_id);
      auto* p = curve.add_points();
      p->set_attempt(static_cast<uint32_t>(curve.points_size()));
      p->set_start_unix_ms(r.start_unix_ms);
      p->set_score(r.score);
      p->set_completed(r.completed);
      p->set_time_to_cecum_s(r.time_to_cecum_s);
      p->set_uuid(r.uuid);
    }
    response->set_trainee_id(trainee.trainee_id);
    for (auto& [id, curve] : curves) *response->add_curves() = std::move(curve);
    return Status::OK;
  });
}

grpc::ServerUnaryReactor* TraineesService::GetLearningCurve(
    grpc::CallbackServerContext* ctx, const ves::v1::LearningCurveRequest* request,
    ves::v1::LearningCurveResponse* response) {
  return ServeUnary(ctx, deps_, request, response, &GetLearningCurveCall);
}

Status GetSessionCall(const ServiceDeps& deps, const Principal& who,
                      const ves::v1::GetSessionRequest& request,
                      ves::v1::GetSessionResponse* response) {
  static const CallSpec spec{"session.read",
                             {StoreRole::kAdmin, StoreRole::kSupervisor, StoreRole::kTrainee},
                             "read sessions"};
  return RunCall(deps, who, spec, request.uuid(), [&]() -> Status {
    auto row = deps.store->GetSession(request.uuid());
    if (!row.ok()) return ToGrpcStatus(row.status);
    patient_db::TraineeRow trainee;
    Status s = ReadableTrainee(deps, who, row.value.trainee_id, "read the sessions", &trainee);
    if (s.error_code() == StatusCode::NOT_FOUND) {
      return Status(StatusCode::NOT_FOUND, "no session '" + request.uuid() + "'");
    }
    if (!s.ok()) return s;
    if (!response->mutable_record()->ParseFromString(row.value.body)) {
      return Status(StatusCode::DATA_LOSS, "stored session " + request.uuid() + " is corrupt");
    }
    response->set_stored_unix_ms(row.value.stored_unix_ms);
    return Status::OK;
  });
}

grpc::ServerUnaryReactor* TraineesService::GetSession(grpc::CallbackServerContext* ctx,
                                                      const ves::v1::GetSessionRequest* request,
                                                      ves::v1::GetSessionResponse* response) {
  return ServeUnary(ctx, deps_, request, response, &GetSessionCall);
}

// ---- Admin -----------------------------------------------------------------

Status CreateTokenCall(const ServiceDeps& deps, const Principal& who,
                       const ves::v1::CreateTokenRequest& request,
                       ves::v1::CreateTokenResponse* response) {
  const std::string institution =
      request.institution().empty() ? who.institution : request.institution();
  static const CallSpec spec{"token.create", {StoreRole::kAdmin}, "create tokens"};
  const std::string target =
      std::string(patient_db::RoleName(static_cast<StoreRole>(
          request.role() >= 1 && request.role() <= 4 ? request.role() : 4))) +
      "@" + institution;
  return RunCall(deps, who, spec, target, [&]() -> Status {
    const int role = request.role();
    if (role < 1 || role > 4) {
      return Status(StatusCode::INVALID_ARGUMENT,
                    "role = " + std::to_string(role) + ": must be admin, supervisor, station "
                    "or trainee");
    }
    if (!IsName(institution)) {
      return Status(StatusCode::INVALID_ARGUMENT,
                    "institution = '" + institution + "': not a valid name");
    }
    patient_db::TokenRow row;
    row.role = static_cast<StoreRole>(role);
    row.institution = institution;
    row.label = request.label();
    row.created_unix_ms = NowUnixMs();
    if (row.role == StoreRole::kTrainee) {
      auto trainee = deps.store->GetTrainee(request.trainee_id());
      if (!trainee.ok()) {
        return Status(StatusCode::FAILED_PRECONDITION,
                      "trainee_id = '" + request.trainee_id() + "': " + trainee.status.message);
      }
      if (trainee.value.institution != institution) {
        return Status(StatusCode::INVALID_ARGUMENT,
                      "trainee '" + request.trainee_id() + "' belongs to institution '" +
                          trainee.value.institution + "', not '" + institution + "'");
      }
      row.trainee_id = request.trainee_id();
    }
    auto st = deps.store->AddInstitution(institution, row.created_unix_ms);
    const std::string token = NewToken();
    row.token_sha256_hex = Sha256HexOf(token);
    if (st.ok()) st = deps.store->AddToken(row);
    if (!st.ok()) return ToGrpcStatus(st);
    response->set_token(token);
    response->set_token_id(TokenIdOf(row.token_sha256_hex));
    return Status::OK;
  });
}

grpc::ServerUnaryReactor* AdminService::CreateToken(grpc::CallbackServerContext* ctx,
                                                    const ves::v1::CreateTokenRequest* request,
                                                    ves::v1::CreateTokenResponse* response) {
  return ServeUnary(ctx, deps_, request, response, &CreateTokenCall);
}

Status ListAuditCall(const ServiceDeps& deps, const Principal& who,
                     const ves::v1::ListAuditRequest& request,
                     ves::v1::ListAuditResponse* response) {
  static const CallSpec spec{"audit.list",
                             {StoreRole::kAdmin},
                             "read the audit log",
                             /*audit_every_call=*/false};
  return RunCall(deps, who, spec, "", [&]() -> Status {
    const int size = PageSizeOf(request.limit(), patient_db::kMaxPageSize);
    patient_db::ListPage page;
    const Status token = ReadPageToken(request.page_token(), "audit", &page);
    if (!token.ok()) return token;
    auto rows = deps.store->ListAudit(request.since_unix_ms(), size + 1,
                                      page.has_after ? page.after_number : 0);
    if (!rows.ok()) return ToGrpcStatus(rows.status);
    if (static_cast<int>(rows.value.size()) > size) {
      rows.value.resize(size);
      response->set_next_page_token(MakePageToken("audit", rows.value.back().id, ""));
    }
    for (const auto& r : rows.value) {
      auto* e = response->add_entries();
      e->set_id(r.id);
      e->set_at_unix_ms(r.at_unix_ms);
      e->set_actor(r.actor);
      e->set_actor_label(r.actor_label);
      StoreRole role = StoreRole::kTrainee;
      e->set_role(patient_db::ParseRoleName(r.role, &role) ? ToProtoRole(role)
                                                           : ves::v1::ROLE_UNSPECIFIED);
      e->set_institution(r.institution);
      e->set_action(r.action);
      e->set_target(r.target);
      e->set_result(r.result);
    }
    return Status::OK;
  });
}

Status ListStationsCall(const ServiceDeps& deps, const Principal& who,
                        const ves::v1::ListStationsRequest& request,
                        ves::v1::ListStationsResponse* response) {
  const std::string institution =
      request.institution().empty() ? who.institution : request.institution();
  static const CallSpec spec{
      "station.list", {StoreRole::kAdmin, StoreRole::kSupervisor}, "list stations"};
  return RunCall(deps, who, spec, institution, [&]() -> Status {
    AuthStatus a = RequireInstitution(who, institution, "list the stations");
    if (!a.ok()) return ToGrpcStatus(a);
    patient_db::ListPage page;
    const Status token = ReadPageToken(request.page_token(), "stations", &page);
    if (!token.ok()) return token;
    const int size = PageSizeOf(request.page_size());
    page.limit = size + 1;  // one more tells whether a next page exists
    auto rows = deps.store->ListStations(institution, page);
    if (!rows.ok()) return ToGrpcStatus(rows.status);
    for (int i = 0; i < static_cast<int>(rows.value.size()) && i < size; ++i) {
      const patient_db::StationRow& r = rows.value[i];
      auto* out = response->add_stations();
      out->set_station_id(r.station_id);
      out->set_institution(r.institution);
      out->set_last_seen_unix_ms(r.last_seen_unix_ms);
      out->set_software_version(r.software_version);
      if (r.has_health) {
        ToStationHealth(r.health, out->mutable_health());
        out->set_health_session_uuid(r.health_session_uuid);
        out->set_health_session_end_unix_ms(r.health_session_end_unix_ms);
      }
      if (i + 1 == size && i + 1 < static_cast<int>(rows.value.size())) {
        response->set_next_page_token(MakePageToken("stations", 0, r.station_id));
      }
    }
    return Status::OK;
  });
}

grpc::ServerUnaryReactor* AdminService::ListStations(grpc::CallbackServerContext* ctx,
                                                     const ves::v1::ListStationsRequest* request,
                                                     ves::v1::ListStationsResponse* response) {
  return ServeUnary(ctx, deps_, request, response, &ListStationsCall);
}

grpc::ServerUnaryReactor* AdminService::ListAudit(grpc::CallbackServerContext* ctx,
                                                  const ves::v1::ListAuditRequest* request,
                                                  ves::v1::ListAuditResponse* response) {
  return ServeUnary(ctx, deps_, request, response, &ListAuditCall);
}

}  // namespace ves::server
