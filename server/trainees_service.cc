// The Trainees service: trainees, their sessions, learning curves and stored
// records; and the CSV export's read (ExportSessionsCall) the web API serves.
#include <map>

#include "patient_db/limits.h"
#include "server/pipeline.h"
#include "server/services.h"

namespace ves::server {

using grpc::Status;
using grpc::StatusCode;
using patient_db::StoreRole;

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

}  // namespace

Status AddTraineeCall(const ServiceDeps& deps, const Principal& who,
                      const ves::v1::AddTraineeRequest& request,
                      ves::v1::AddTraineeResponse* response) {
  const ves::v1::Trainee& t = request.trainee();
  static const CallSpec spec{
      "trainee.add", {StoreRole::kAdmin, StoreRole::kSupervisor}, "add trainees"};
  return RunCall(deps, who, spec, t.trainee_id(), [&]() -> Status {
    if (!patient_db::IsPrintableId(t.trainee_id())) {
      return Status(StatusCode::INVALID_ARGUMENT,
                    "trainee.trainee_id = '" + t.trainee_id() + "': must be 1..128 printable "
                    "characters");
    }
    patient_db::TraineeRow row{t.trainee_id(),
                               t.institution().empty() ? who.institution : t.institution(),
                               t.display_name(), NowUnixMs()};
    if (!patient_db::IsPrintableId(row.institution)) {
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
}  // namespace ves::server
