// Lessons service: curricula, assignments, next lesson, progress and verdicts
// (docs/lessons.md). Thin handlers over the Store; the rules are in
// lesson_rules.h, the judging in lesson_judge.h.
#include <google/protobuf/io/coded_stream.h>
#include <google/protobuf/io/zero_copy_stream_impl_lite.h>

#include <algorithm>

#include "patient_db/case_bundle.h"
#include "server/lesson_rules.h"
#include "server/pipeline.h"
#include "server/services.h"
#include "station/training/case_run.h"

namespace ves::server {

using grpc::Status;
using grpc::StatusCode;
using patient_db::StoreCode;
using patient_db::StoreRole;

namespace {

// Pins the lesson's case to a stored version the institution may use (by
// payload hash when the file gives one, else the latest version), fills the
// default scope and passes, and checks that case, scope and time limit build
// a model.
Status PinLesson(patient_db::Store& store, const std::string& institution, int index,
                 ves::v1::Lesson* lesson) {
  const std::string at =
      "curriculum.lessons[" + std::to_string(index) + "] ('" + lesson->lesson_id() + "')";
  ves::v1::CaseRef& ref = *lesson->mutable_case_ref();
  patient_db::CaseFilter filter;
  filter.all_versions = true;
  filter.visible_to = institution;
  auto visible = store.ListCases(filter);
  if (!visible.ok()) return ToGrpcStatus(visible.status);
  const patient_db::CaseRow* pinned = nullptr;
  for (const auto& row : visible.value) {
    if (row.case_id != ref.case_id()) continue;
    if (ref.version() != 0 && row.version != ref.version()) continue;
    if (!ref.payload_sha256_hex().empty() && row.payload_sha256_hex != ref.payload_sha256_hex()) {
      continue;
    }
    pinned = &row;  // rows come by version: the last match is the latest
  }
  if (pinned == nullptr) {
    std::string want = "case '" + ref.case_id() + "'";
    if (ref.version() != 0) want += " version " + std::to_string(ref.version());
    if (!ref.payload_sha256_hex().empty()) {
      want += " with payload sha256 " + ref.payload_sha256_hex();
    }
    return Status(StatusCode::FAILED_PRECONDITION,
                  at + ": " + want + " is not on the server for institution '" + institution +
                      "' (upload the case first)");
  }
  ref.set_version(pinned->version);
  ref.set_payload_sha256_hex(pinned->payload_sha256_hex);
  if (!lesson->has_scope()) *lesson->mutable_scope() = training::DefaultEndoscopeSpec();
  if (lesson->required_passes() == 0) lesson->set_required_passes(1);
  auto blob = store.GetBlob(pinned->sha256_hex);
  if (!blob.ok()) return ToGrpcStatus(blob.status);
  try {
    training::PrepareCaseRun(patient_db::DecodeCaseBundle(blob.value, ref.case_id()),
                             lesson->scope(), {}, lesson->time_limit_s());
  } catch (const std::exception& error) {
    return Status(StatusCode::INVALID_ARGUMENT, at + ": cannot run: " + error.what());
  }
  return Status::OK;
}

// May `who` read this trainee's lessons? Admin; supervisor or station of the
// trainee's institution; the trainee themself.
Status LessonReader(const ServiceDeps& deps, const Principal& who, const std::string& trainee_id,
                    const std::string& what, patient_db::TraineeRow* trainee) {
  AuthStatus a = RequireRole(who, {StoreRole::kAdmin, StoreRole::kSupervisor,
                                   StoreRole::kStation, StoreRole::kTrainee}, what);
  if (!a.ok()) return ToGrpcStatus(a);
  auto found = deps.store->GetTrainee(trainee_id);
  if (!found.ok()) return ToGrpcStatus(found.status);
  a = who.role == StoreRole::kStation ? RequireInstitution(who, found.value.institution, what)
                                      : RequireTraineeReader(who, found.value, what);
  // As for an absent trainee: existence is not told outside the institution.
  if (!a.ok()) return Status(StatusCode::NOT_FOUND, "no trainee '" + trainee_id + "'");
  *trainee = found.value;
  return Status::OK;
}

// The trainee's progress over every assigned curriculum.
Status ProgressOf(const ServiceDeps& deps, const std::string& trainee_id, Progress* progress,
                  ves::v1::TraineeProgress* out) {
  auto assignments = deps.store->ListAssignments(trainee_id);
  if (!assignments.ok()) return ToGrpcStatus(assignments.status);
  std::vector<ves::v1::Curriculum> assigned;
  for (const auto& a : assignments.value) {
    auto row = deps.store->GetCurriculum(a.curriculum_id);
    if (!row.ok()) return ToGrpcStatus(row.status);
    if (!assigned.emplace_back().ParseFromString(row.value.body)) {
      return Status(StatusCode::DATA_LOSS, "stored curriculum " + a.curriculum_id + " is corrupt");
    }
  }
  auto verdicts = deps.store->ListLessonVerdicts(trainee_id);
  if (!verdicts.ok()) return ToGrpcStatus(verdicts.status);
  auto pending = deps.store->ListUnjudgedLessonSessions(trainee_id, 10000);
  if (!pending.ok()) return ToGrpcStatus(pending.status);
  auto group = deps.store->GetTraineeGroup(trainee_id);
  if (!group.ok()) return ToGrpcStatus(group.status);
  *progress = CalcProgress(assigned, verdicts.value);
  out->set_trainee_id(trainee_id);
  out->set_group(group.value);
  for (const auto& l : progress->lessons) *out->add_lessons() = l;
  if (progress->has_next) out->set_next_lesson_id(progress->next.lesson_id());
  out->set_pending_verdicts(static_cast<uint32_t>(pending.value.size()));
  return Status::OK;
}

void ToProtoVerdict(const patient_db::LessonVerdictRow& v, ves::v1::LessonVerdict* out) {
  out->set_session_uuid(v.session_uuid);
  out->set_trainee_id(v.trainee_id);
  out->set_curriculum_id(v.curriculum_id);
  out->set_lesson_id(v.lesson_id);
  out->set_passed(v.passed);
  out->set_rejected(v.rejected);
  out->set_score(v.score);
  size_t start = 0;
  while (start < v.detail.size()) {
    const size_t end = std::min(v.detail.find('\n', start), v.detail.size());
    out->add_checks(v.detail.substr(start, end - start));
    start = end + 1;
  }
  out->set_judged_unix_ms(v.judged_unix_ms);
  out->set_session_start_unix_ms(v.session_start_unix_ms);
}

}  // namespace

Status CreateCurriculumCall(const ServiceDeps& deps, const Principal& who,
                            const ves::v1::CreateCurriculumRequest& request_message,
                            ves::v1::CreateCurriculumResponse* response) {
  const ves::v1::CreateCurriculumRequest* request = &request_message;
  ves::v1::Curriculum c = request->curriculum();
  static const CallSpec spec{
      "curriculum.create", {StoreRole::kAdmin, StoreRole::kSupervisor}, "create curricula"};
  return RunCall(deps, who, spec, c.curriculum_id(), [&]() -> Status {
    const std::string institution = c.institution().empty() ? who.institution : c.institution();
    AuthStatus a = RequireInstitution(who, institution, "create curricula for the institution");
    if (!a.ok()) return ToGrpcStatus(a);
    const std::string problem = CheckCurriculum(c);
    if (!problem.empty()) return Status(StatusCode::INVALID_ARGUMENT, "curriculum." + problem);
    c.set_institution(institution);
    for (int i = 0; i < c.lessons_size(); ++i) {
      Status s = PinLesson(*deps.store, institution, i, c.mutable_lessons(i));
      if (!s.ok()) return s;
    }
    patient_db::CurriculumRow row;
    row.curriculum_id = c.curriculum_id();
    row.institution = institution;
    row.title = c.title();
    for (const auto& l : c.lessons()) row.lesson_ids.push_back(l.lesson_id());
    row.created_by = who.token_id;
    row.created_unix_ms = NowUnixMs();
    row.body = patient_db::SerializeDeterministic(c);
    row.body_sha256_hex = Sha256Hex(row.body);
    auto put = deps.store->PutCurriculum(row);
    if (!put.ok()) return ToGrpcStatus(put.status);
    *response->mutable_curriculum() = c;
    response->set_already_stored(put.value);
    return Status::OK;
  });
}

grpc::ServerUnaryReactor* LessonsService::CreateCurriculum(
    grpc::CallbackServerContext* ctx, const ves::v1::CreateCurriculumRequest* request,
    ves::v1::CreateCurriculumResponse* response) {
  return ServeUnary(ctx, deps_, request, response, &CreateCurriculumCall);
}

Status ListCurriculaCall(const ServiceDeps& deps, const Principal& who,
                         const ves::v1::ListCurriculaRequest& request_message,
                         ves::v1::ListCurriculaResponse* response) {
  const ves::v1::ListCurriculaRequest* request = &request_message;
  const std::string institution =
      request->institution().empty() ? who.institution : request->institution();
  static const CallSpec spec{"curriculum.list",
                             {StoreRole::kAdmin, StoreRole::kSupervisor, StoreRole::kStation},
                             "list curricula"};
  return RunCall(deps, who, spec, institution, [&]() -> Status {
    AuthStatus a = RequireInstitution(who, institution, "list the curricula");
    if (!a.ok()) return ToGrpcStatus(a);
    patient_db::ListPage page;
    const Status token = ReadPageToken(request->page_token(), "curricula", &page);
    if (!token.ok()) return token;
    // Curricula are large (up to 200 lessons each): ten a page by default.
    const int size = PageSizeOf(request->page_size(), 10);
    page.limit = size + 1;
    auto rows = deps.store->ListCurricula(institution, page);
    if (!rows.ok()) return ToGrpcStatus(rows.status);
    size_t bytes = 0;
    for (int i = 0; i < static_cast<int>(rows.value.size()) && i < size; ++i) {
      const auto& r = rows.value[i];
      if (!response->add_curricula()->ParseFromString(r.body)) {
        return Status(StatusCode::DATA_LOSS, "stored curriculum " + r.curriculum_id +
                                                 " is corrupt");
      }
      bytes += r.body.size() + 8;
      const bool more = i + 1 < static_cast<int>(rows.value.size());
      if (more && (i + 1 == size || bytes > kPageReplyBudgetBytes)) {
        response->set_next_page_token(MakePageToken("curricula", 0, r.curriculum_id));
        break;
      }
    }
    return Status::OK;
  });
}

grpc::ServerUnaryReactor* LessonsService::ListCurricula(
    grpc::CallbackServerContext* ctx, const ves::v1::ListCurriculaRequest* request,
    ves::v1::ListCurriculaResponse* response) {
  return ServeUnary(ctx, deps_, request, response, &ListCurriculaCall);
}

Status AssignCurriculumCall(const ServiceDeps& deps, const Principal& who,
                            const ves::v1::AssignCurriculumRequest& request_message,
                            ves::v1::AssignCurriculumResponse* response) {
  const ves::v1::AssignCurriculumRequest* request = &request_message;
  const bool to_group = request->has_group();
  const std::string assignee = to_group ? request->group() : request->trainee_id();
  static const CallSpec spec{
      "curriculum.assign", {StoreRole::kAdmin, StoreRole::kSupervisor}, "assign curricula"};
  const std::string target =
      request->curriculum_id() + (to_group ? " group " : " trainee ") + assignee;
  return RunCall(deps, who, spec, target, [&]() -> Status {
    auto curriculum = deps.store->GetCurriculum(request->curriculum_id());
    if (!curriculum.ok()) return ToGrpcStatus(curriculum.status);
    const std::string& institution = curriculum.value.institution;
    // Another institution's curriculum answers as an absent one (no existence leak).
    if (!RequireInstitution(who, institution, "assign").ok()) {
      return Status(StatusCode::NOT_FOUND, "no curriculum '" + request->curriculum_id() + "'");
    }
    if (!patient_db::IsPrintableId(assignee)) {
      return Status(StatusCode::INVALID_ARGUMENT,
                    std::string(to_group ? "group" : "trainee_id") + " = '" + assignee +
                        "': give a trainee or a group (1..128 printable characters)");
    }
    if (!to_group) {
      auto trainee = deps.store->GetTrainee(assignee);
      if (!trainee.ok()) return ToGrpcStatus(trainee.status);
      if (trainee.value.institution != institution) {
        return Status(StatusCode::FAILED_PRECONDITION,
                      "trainee '" + assignee + "' belongs to institution '" +
                          trainee.value.institution + "', the curriculum to '" + institution +
                          "'");
      }
    }
    auto st = deps.store->AddAssignment(
        {request->curriculum_id(), to_group, assignee, institution, who.token_id, NowUnixMs()});
    if (!st.ok()) return ToGrpcStatus(st);
    if (to_group) {
      auto members = deps.store->ListGroupTrainees(institution, assignee);
      if (!members.ok()) return ToGrpcStatus(members.status);
      for (const auto& m : members.value) response->add_trainee_ids(m);
    } else {
      response->add_trainee_ids(assignee);
    }
    return Status::OK;
  });
}

grpc::ServerUnaryReactor* LessonsService::AssignCurriculum(
    grpc::CallbackServerContext* ctx, const ves::v1::AssignCurriculumRequest* request,
    ves::v1::AssignCurriculumResponse* response) {
  return ServeUnary(ctx, deps_, request, response, &AssignCurriculumCall);
}

Status SetTraineeGroupCall(const ServiceDeps& deps, const Principal& who,
                           const ves::v1::SetTraineeGroupRequest& request_message,
                           ves::v1::SetTraineeGroupResponse* /*response*/) {
  const ves::v1::SetTraineeGroupRequest* request = &request_message;
  static const CallSpec spec{
      "trainee.group", {StoreRole::kAdmin, StoreRole::kSupervisor}, "set trainee groups"};
  return RunCall(deps, who, spec, request->trainee_id(), [&]() -> Status {
    auto trainee = deps.store->GetTrainee(request->trainee_id());
    if (!trainee.ok()) return ToGrpcStatus(trainee.status);
    if (!RequireInstitution(who, trainee.value.institution, "group").ok()) {
      return Status(StatusCode::NOT_FOUND, "no trainee '" + request->trainee_id() + "'");
    }
    if (!request->group().empty() && !patient_db::IsPrintableId(request->group())) {
      return Status(StatusCode::INVALID_ARGUMENT,
                    "group = '" + request->group() + "': must be 1..128 printable characters");
    }
    return ToGrpcStatus(deps.store->SetTraineeGroup(request->trainee_id(), request->group()));
  });
}

grpc::ServerUnaryReactor* LessonsService::SetTraineeGroup(
    grpc::CallbackServerContext* ctx, const ves::v1::SetTraineeGroupRequest* request,
    ves::v1::SetTraineeGroupResponse* response) {
  return ServeUnary(ctx, deps_, request, response, &SetTraineeGroupCall);
}

Status GetNextLessonCall(const ServiceDeps& deps, const Principal& who,
                         const ves::v1::GetNextLessonRequest& request_message,
                         ves::v1::GetNextLessonResponse* response) {
  const ves::v1::GetNextLessonRequest* request = &request_message;
  static const CallSpec spec{
      "lesson.next",
      {StoreRole::kAdmin, StoreRole::kSupervisor, StoreRole::kStation, StoreRole::kTrainee},
      "get lessons"};
  return RunCall(deps, who, spec, request->trainee_id(), [&]() -> Status {
    patient_db::TraineeRow trainee;
    Status s = LessonReader(deps, who, request->trainee_id(), "get lessons", &trainee);
    if (!s.ok()) return s;
    Progress progress;
    ves::v1::TraineeProgress summary;
    s = ProgressOf(deps, trainee.trainee_id, &progress, &summary);
    if (!s.ok()) return s;
    response->set_pending_verdicts(summary.pending_verdicts());
    if (!progress.has_next) {
      response->set_available(false);
      response->set_note(progress.lessons.empty()
                             ? "no curriculum is assigned to trainee '" + trainee.trainee_id + "'"
                             : "every assigned lesson is completed");
      return Status::OK;
    }
    response->set_available(true);
    *response->mutable_lesson() = progress.next;
    response->set_curriculum_id(progress.next_curriculum_id);
    response->set_curriculum_title(progress.next_curriculum_title);
    response->set_lesson_number(progress.next_number);
    response->set_lesson_count(progress.next_count);
    response->set_passes(progress.next_passes);
    return Status::OK;
  });
}

grpc::ServerUnaryReactor* LessonsService::GetNextLesson(
    grpc::CallbackServerContext* ctx, const ves::v1::GetNextLessonRequest* request,
    ves::v1::GetNextLessonResponse* response) {
  return ServeUnary(ctx, deps_, request, response, &GetNextLessonCall);
}

Status GetProgressCall(const ServiceDeps& deps, const Principal& who,
                       const ves::v1::GetProgressRequest& request,
                       ves::v1::GetProgressResponse* response) {
  const bool by_group = request.has_group();
  const std::string institution =
      request.institution().empty() ? who.institution : request.institution();
  // Every reader of progress; a group's needs admin or supervisor (below).
  static const CallSpec spec{
      "lesson.progress",
      {StoreRole::kAdmin, StoreRole::kSupervisor, StoreRole::kStation, StoreRole::kTrainee},
      "read progress"};
  return RunCall(deps, who, spec,
                 by_group ? "group " + request.group() + "@" + institution : request.trainee_id(),
                 [&]() -> Status {
                   std::vector<std::string> trainees;
                   if (by_group) {
                     AuthStatus a = RequireRole(who, {StoreRole::kAdmin, StoreRole::kSupervisor},
                                                "read a group's progress");
                     if (a.ok()) a = RequireInstitution(who, institution, "read the groups");
                     if (!a.ok()) return ToGrpcStatus(a);
                     auto members = deps.store->ListGroupTrainees(institution, request.group());
                     if (!members.ok()) return ToGrpcStatus(members.status);
                     if (members.value.empty()) {
                       return Status(StatusCode::NOT_FOUND, "group '" + request.group() +
                                                                "' of institution '" + institution +
                                                                "' has no trainees");
                     }
                     trainees = members.value;
                   } else {
                     patient_db::TraineeRow trainee;
                     Status s =
                         LessonReader(deps, who, request.trainee_id(), "read progress", &trainee);
                     if (!s.ok()) return s;
                     trainees.push_back(trainee.trainee_id);
                   }
                   for (const std::string& id : trainees) {
                     Progress progress;
                     Status s = ProgressOf(deps, id, &progress, response->add_trainees());
                     if (!s.ok()) return s;
                   }
                   return Status::OK;
                 });
}

grpc::ServerUnaryReactor* LessonsService::GetProgress(grpc::CallbackServerContext* ctx,
                                                      const ves::v1::GetProgressRequest* request,
                                                      ves::v1::GetProgressResponse* response) {
  return ServeUnary(ctx, deps_, request, response, &GetProgressCall);
}

Status GetLessonVerdictCall(const ServiceDeps& deps, const Principal& who,
                            const ves::v1::GetLessonVerdictRequest& request_message,
                            ves::v1::GetLessonVerdictResponse* response) {
  const ves::v1::GetLessonVerdictRequest* request = &request_message;
  static const CallSpec spec{
      "lesson.verdict",
      {StoreRole::kAdmin, StoreRole::kSupervisor, StoreRole::kStation, StoreRole::kTrainee},
      "read verdicts"};
  return RunCall(deps, who, spec, request->session_uuid(), [&]() -> Status {
    auto session = deps.store->GetSession(request->session_uuid());
    if (!session.ok()) return ToGrpcStatus(session.status);
    patient_db::TraineeRow trainee;
    Status s = LessonReader(deps, who, session.value.trainee_id, "read verdicts", &trainee);
    if (s.error_code() == StatusCode::NOT_FOUND) {
      return Status(StatusCode::NOT_FOUND, "no session '" + request->session_uuid() + "'");
    }
    if (!s.ok()) return s;
    auto verdict = deps.store->GetLessonVerdict(request->session_uuid());
    if (verdict.ok()) {
      response->set_judged(true);
      ToProtoVerdict(verdict.value, response->mutable_verdict());
      return Status::OK;
    }
    if (verdict.status.code != StoreCode::kNotFound) return ToGrpcStatus(verdict.status);
    ves::v1::SessionRecord record;
    if (!record.ParseFromString(session.value.body)) {
      return Status(StatusCode::DATA_LOSS, "stored session is corrupt");
    }
    if (record.lesson_id().empty()) {
      return Status(StatusCode::FAILED_PRECONDITION,
                    "session " + request->session_uuid() + " was not run as a lesson");
    }
    response->set_judged(false);  // stored; the judge has not reached it yet
    return Status::OK;
  });
}

grpc::ServerUnaryReactor* LessonsService::GetLessonVerdict(
    grpc::CallbackServerContext* ctx, const ves::v1::GetLessonVerdictRequest* request,
    ves::v1::GetLessonVerdictResponse* response) {
  return ServeUnary(ctx, deps_, request, response, &GetLessonVerdictCall);
}

}  // namespace ves::server
