#include "server/web_cohort.h"

#include <algorithm>
#include <iterator>
#include <tuple>

#include "server/lesson_rules.h"
#include "server/pipeline.h"
#include "server/web_reply.h"
#include "server/web_routes.h"
#include "ves/v1/services.pb.h"

namespace ves::server {

using grpc::Status;
using grpc::StatusCode;
using nlohmann::json;

json MedianOf(std::vector<double> v) {
  if (v.empty()) return nullptr;
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

namespace {

json RangeOf(const std::vector<double>& v) {
  if (v.empty()) return nullptr;
  const auto [lo, hi] = std::minmax_element(v.begin(), v.end());
  return json::array({*lo, *hi});
}

bool InRange(const patient_db::SessionRow& s, int64_t from_unix_ms, int64_t to_unix_ms) {
  return s.start_unix_ms >= from_unix_ms && (to_unix_ms == 0 || s.start_unix_ms < to_unix_ms);
}

// The trainee's sessions started in [from, to) (to 0: no bound), oldest
// first, at most `limit` + 1 (so that a caller can tell there were more).
patient_db::StoreResult<std::vector<patient_db::SessionRow>> SessionsIn(
    patient_db::Store& store, const std::string& trainee_id, int64_t from_unix_ms,
    int64_t to_unix_ms, int limit) {
  patient_db::ListPage page;  // the listing's key is (start, uuid): from the first at `from`
  page.has_after = from_unix_ms > 0;
  page.after_number = from_unix_ms;
  page.limit = limit + 1;
  auto rows = store.ListSessions(trainee_id, "", page);
  if (!rows.ok()) return rows;
  auto end = std::find_if(rows.value.begin(), rows.value.end(), [&](const auto& s) {
    return !InRange(s, from_unix_ms, to_unix_ms);
  });
  rows.value.erase(end, rows.value.end());
  return rows;
}

// {"lesson": figures of the lesson attempts, "practice": of the free runs}.
json SplitFiguresJson(const std::vector<patient_db::SessionRow>& rows) {
  std::vector<const patient_db::SessionRow*> lesson, practice;
  for (const auto& r : rows) (r.lesson_id.empty() ? practice : lesson).push_back(&r);
  return {{"lesson", RunFiguresJson(lesson)}, {"practice", RunFiguresJson(practice)}};
}

const std::string& GroupInstitution(const std::map<std::string, std::string>& query,
                                    const Principal& who) {
  auto it = query.find("institution");
  return it == query.end() || it->second.empty() ? who.institution : it->second;
}

// The members of the group (admin, or a supervisor of its institution);
// NOT_FOUND when it has none, as Lessons.GetProgress answers.
Status GroupMembers(const ServiceDeps& deps, const Principal& who, const std::string& institution,
                    const std::string& group, std::vector<std::string>* members) {
  AuthStatus a = RequireInstitution(who, institution, "read the groups");
  if (!a.ok()) return ToGrpcStatus(a);
  auto listed = deps.store->ListGroupTrainees(institution, group);
  if (!listed.ok()) return ToGrpcStatus(listed.status);
  if (listed.value.empty()) {
    return Status(StatusCode::NOT_FOUND,
                  "group '" + group + "' of institution '" + institution + "' has no trainees");
  }
  *members = std::move(listed.value);
  return Status::OK;
}

std::string VerdictText(const patient_db::LessonVerdictRow* v) {
  if (v == nullptr) return "pending";
  return v->rejected ? "rejected" : v->passed ? "passed" : "failed";
}

}  // namespace

const v1::Curriculum* CurriculumCache::Get(const std::string& curriculum_id) {
  auto it = curricula_.find(curriculum_id);
  if (it == curricula_.end()) {
    std::optional<v1::Curriculum> parsed;
    auto row = store_->GetCurriculum(curriculum_id);
    if (row.ok() && parsed.emplace().ParseFromString(row.value.body)) {
      it = curricula_.emplace(curriculum_id, std::move(parsed)).first;
    } else {
      it = curricula_.emplace(curriculum_id, std::nullopt).first;
    }
  }
  return it->second ? &*it->second : nullptr;
}

json CurriculaProgressJson(patient_db::Store& store, CurriculumCache& curricula,
                           const std::string& trainee_id, bool detail) {
  auto assignments = store.ListAssignments(trainee_id);
  if (!assignments.ok() || assignments.value.empty()) return json::array();
  auto verdicts = store.ListLessonVerdicts(trainee_id);
  if (!verdicts.ok()) return json::array();
  return CurriculaProgressJson(curricula, assignments.value, verdicts.value, detail);
}

json CurriculaProgressJson(CurriculumCache& curricula,
                           const std::vector<patient_db::AssignmentRow>& assignments,
                           const std::vector<patient_db::LessonVerdictRow>& verdicts,
                           bool detail) {
  json out = json::array();
  if (assignments.empty()) return out;
  std::vector<v1::Curriculum> assigned;
  for (const auto& a : assignments) {
    if (const v1::Curriculum* c = curricula.Get(a.curriculum_id)) assigned.push_back(*c);
  }
  const Progress progress = CalcProgress(assigned, verdicts);
  std::map<std::string, size_t> index;  // curriculum id -> its entry in `out`
  for (const v1::LessonProgress& l : progress.lessons) {
    auto [it, fresh] = index.emplace(l.curriculum_id(), out.size());
    if (fresh) {
      const v1::Curriculum* c = curricula.Get(l.curriculum_id());
      out.push_back({{"curriculum_id", l.curriculum_id()},
                     {"title", c ? c->title() : ""},
                     {"lessons", 0},
                     {"passed", 0},
                     {"proficient", false}});
      if (detail) out.back()["lesson_progress"] = json::array();
    }
    json& entry = out[it->second];
    entry["lessons"] = entry["lessons"].get<int>() + 1;
    if (l.completed()) entry["passed"] = entry["passed"].get<int>() + 1;
    if (detail) {
      entry["lesson_progress"].push_back({{"lesson_id", l.lesson_id()},
                                          {"title", l.title()},
                                          {"attempts", l.attempts()},
                                          {"passes", l.passes()},
                                          {"required_passes", l.required_passes()},
                                          {"best_score", l.best_score()},
                                          {"completed", l.completed()}});
    }
  }
  for (json& entry : out) entry["proficient"] = entry["passed"] == entry["lessons"];
  return out;
}

json RunFiguresJson(const std::vector<const patient_db::SessionRow*>& runs) {
  std::vector<double> cecum, pain, loop, xray;
  int reached = 0;
  double best = 0;
  const patient_db::SessionRow* last = nullptr;
  for (const patient_db::SessionRow* r : runs) {
    if (r->completed) {
      ++reached;
      cecum.push_back(r->time_to_cecum_s);
    }
    pain.push_back(r->pain_s);
    if (r->loop_s >= 0) loop.push_back(r->loop_s);
    if (r->xray_s >= 0) xray.push_back(r->xray_s);
    best = last == nullptr ? r->score : std::max(best, r->score);
    if (last == nullptr || r->start_unix_ms >= last->start_unix_ms) last = r;
  }
  return {{"attempts", runs.size()},
          {"cecum_reached", reached},
          {"best_score", last ? json(best) : json(nullptr)},
          {"last_score", last ? json(last->score) : json(nullptr)},
          {"last_unix_ms", last ? last->start_unix_ms : 0},
          {"time_to_cecum_s", MedianOf(cecum)},
          {"pain_s", MedianOf(pain)},
          {"loop_s", MedianOf(loop)},
          {"xray_s", MedianOf(xray)}};
}

json ExpertBandJson(patient_db::Store& store, const std::string& institution,
                    const std::string& case_id) {
  auto runs = store.ListOperatorSessions(institution, case_id, "expert", kMaxExpertBandRuns);
  if (!runs.ok() || runs.value.empty()) return nullptr;
  std::vector<double> score, cecum, pain, loop;
  for (const auto& r : runs.value) {
    score.push_back(r.score);
    if (r.completed) cecum.push_back(r.time_to_cecum_s);
    pain.push_back(r.pain_s);
    if (r.loop_s >= 0) loop.push_back(r.loop_s);
  }
  return {{"runs", runs.value.size()},
          {"score", RangeOf(score)},
          {"time_to_cecum_s", RangeOf(cecum)},
          {"pain_s", RangeOf(pain)},
          {"loop_s", RangeOf(loop)}};
}

namespace {

// GET trainees/{id}/report: the printable report. The export's read rules
// and audit row: a printed report is an export.
HttpReply TraineeReport(WebCall& call) {
  const std::string& id = call.Param("id");
  TraineeExport read;
  if (auto refused = ReadTraineeExport(call, &read)) return *refused;
  const std::vector<patient_db::SessionRow>& sessions = read.sessions;
  const int64_t from = read.from_unix_ms, to = read.to_unix_ms;
  patient_db::Store& store = *call.deps.store;
  auto trainee = store.GetTrainee(id);
  auto group = store.GetTraineeGroup(id);
  if (!trainee.ok()) return ErrorOf(ToGrpcStatus(trainee.status));
  std::map<std::string, const patient_db::LessonVerdictRow*> verdict_of;
  for (const auto& v : read.verdicts) verdict_of[v.session_uuid] = &v;
  json rows = json::array();
  for (const auto& r : sessions) {
    auto v = verdict_of.find(r.uuid);
    rows.push_back(
        {{"uuid", r.uuid},
         {"start_unix_ms", r.start_unix_ms},
         {"case_id", r.case_id},
         {"lesson_id", r.lesson_id},
         {"verdict", r.lesson_id.empty()
                         ? ""
                         : VerdictText(v == verdict_of.end() ? nullptr : v->second)},
         {"outcome", v1::Outcome_IsValid(r.outcome)
                         ? v1::Outcome_Name(static_cast<v1::Outcome>(r.outcome))
                         : "OUTCOME_UNSPECIFIED"},
         {"score", r.score},
         {"time_to_cecum_s", r.completed ? json(r.time_to_cecum_s) : json(nullptr)},
         {"pain_s", r.pain_s},
         {"loop_s", r.loop_s >= 0 ? json(r.loop_s) : json(nullptr)},
         {"xray_s", r.xray_s >= 0 ? json(r.xray_s) : json(nullptr)}});
  }
  CurriculumCache curricula(&store);
  json out = SplitFiguresJson(sessions);
  out["trainee_id"] = trainee.value.trainee_id;
  out["display_name"] = trainee.value.display_name;
  out["institution"] = trainee.value.institution;
  out["group"] = group.ok() ? group.value : "";
  out["from_unix_ms"] = from;
  out["to_unix_ms"] = to;
  out["generated_unix_ms"] = NowUnixMs();
  out["curricula"] = CurriculaProgressJson(store, curricula, id, /*detail=*/true);
  out["sessions"] = std::move(rows);
  return JsonReply(200, out);
}

// The time range and the admission of a group route; false with the refusal.
bool AdmitGroupCall(WebCall& call, int64_t* from, int64_t* to, HttpReply* refusal) {
  if (!QueryTimeRange(call.query, from, to, refusal)) return false;
  v1::GetProgressRequest req;  // the group's and institution's bounds
  req.set_group(call.Param("group"));
  auto inst = call.query.find("institution");
  if (inst != call.query.end()) req.set_institution(inst->second);
  Status s = call.Admit(req);
  if (!s.ok()) *refusal = ErrorOf(s);
  return s.ok();
}

// GET groups/{group}/sessions.csv: the group's sessions in the range.
HttpReply GroupSessionsCsv(WebCall& call) {
  int64_t from = 0, to = 0;
  HttpReply refusal;
  if (!AdmitGroupCall(call, &from, &to, &refusal)) return refusal;
  const std::string& group = call.Param("group");
  const std::string institution = GroupInstitution(call.query, call.who);
  static const CallSpec spec{"session.export", kSupervisors, "export a group's sessions"};
  std::vector<patient_db::SessionRow> sessions;
  std::vector<patient_db::LessonVerdictRow> verdicts;
  const Status s = RunCall(call.deps, call.who, spec, "group " + group + "@" + institution,
                           [&]() -> Status {
    std::vector<std::string> members;
    Status m = GroupMembers(call.deps, call.who, institution, group, &members);
    if (!m.ok()) return m;
    for (const std::string& id : members) {
      auto rows = SessionsIn(*call.deps.store, id, from, to, kMaxExportSessions);
      if (!rows.ok()) return ToGrpcStatus(rows.status);
      if (sessions.size() + rows.value.size() > static_cast<size_t>(kMaxExportSessions)) {
        return Status(StatusCode::OUT_OF_RANGE,
                      "more than " + std::to_string(kMaxExportSessions) + " sessions of group " +
                          group + " in this range: export fewer days at a time");
      }
      std::move(rows.value.begin(), rows.value.end(), std::back_inserter(sessions));
      auto judged = call.deps.store->ListLessonVerdicts(id);
      if (!judged.ok()) return ToGrpcStatus(judged.status);
      std::move(judged.value.begin(), judged.value.end(), std::back_inserter(verdicts));
    }
    std::sort(sessions.begin(), sessions.end(), [](const auto& a, const auto& b) {
      return std::tie(a.start_unix_ms, a.uuid) < std::tie(b.start_unix_ms, b.uuid);
    });
    return Status::OK;
  });
  if (!s.ok()) return ErrorOf(s);
  HttpReply r;
  r.content_type = "text/csv; charset=utf-8";
  r.body = SessionsCsv(sessions, verdicts);
  r.headers.emplace_back("Content-Disposition", "attachment; filename=\"ves-sessions-group-" +
                                                    FileNamePart(group) + ".csv\"");
  return r;
}

// The cohort page's rows: each member's figures and curricula progress.
Status CohortRows(const ServiceDeps& deps, const Principal& who, const std::string& institution,
                  const std::string& group, int64_t from, int64_t to, json* trainees) {
  std::vector<std::string> members;
  Status m = GroupMembers(deps, who, institution, group, &members);
  if (!m.ok()) return m;
  // Progress comes from the members' assignments and verdicts, read for
  // the whole group at once.
  auto assignments = deps.store->ListAssignmentsOf(members);
  if (!assignments.ok()) return ToGrpcStatus(assignments.status);
  auto verdicts = deps.store->ListLessonVerdictsOf(members);
  if (!verdicts.ok()) return ToGrpcStatus(verdicts.status);
  // And their sessions in the range, also in one read: one read per
  // trainee made a 200-trainee group's page take ~230 ms.
  auto sessions = deps.store->ListSessionsOf(members, from, to, kMaxExportSessions);
  if (!sessions.ok()) return ToGrpcStatus(sessions.status);
  CurriculumCache curricula(deps.store);
  for (size_t i = 0; i < members.size(); ++i) {
    const std::string& id = members[i];
    auto trainee = deps.store->GetTrainee(id);
    if (!trainee.ok()) return ToGrpcStatus(trainee.status);
    const std::vector<patient_db::SessionRow>& rows = sessions.value[i];
    if (rows.size() > static_cast<size_t>(kMaxExportSessions)) {
      return Status(StatusCode::OUT_OF_RANGE, "more than " + std::to_string(kMaxExportSessions) +
                                                  " sessions of " + id + " in this range");
    }
    json row = SplitFiguresJson(rows);
    row["trainee_id"] = id;
    row["display_name"] = trainee.value.display_name;
    row["curricula"] = CurriculaProgressJson(curricula, assignments.value[i], verdicts.value[i]);
    trainees->push_back(std::move(row));
  }
  return Status::OK;
}

// GET groups/{group}/cohort: the group page.
HttpReply GroupCohort(WebCall& call) {
  int64_t from = 0, to = 0;
  HttpReply refusal;
  if (!AdmitGroupCall(call, &from, &to, &refusal)) return refusal;
  const std::string& group = call.Param("group");
  const std::string institution = GroupInstitution(call.query, call.who);
  static const CallSpec spec{"group.cohort", kSupervisors, "read a group's figures"};
  json trainees = json::array();
  const Status s =
      RunCall(call.deps, call.who, spec, "group " + group + "@" + institution, [&]() -> Status {
        return CohortRows(call.deps, call.who, institution, group, from, to, &trainees);
      });
  if (!s.ok()) return ErrorOf(s);
  return JsonReply(200, {{"group", group},
                         {"institution", institution},
                         {"from_unix_ms", from},
                         {"to_unix_ms", to},
                         {"trainees", trainees}});
}

// GET groups/{group}/progress: Lessons.GetProgress.
HttpReply GroupProgress(WebCall& call) {
  v1::GetProgressRequest req;
  req.set_group(call.Param("group"));
  req.set_institution(call.Query("institution"));
  v1::GetProgressResponse resp;
  if (auto refused = AdmitAndCall(call, req, &GetProgressCall, &resp)) return *refused;
  return JsonReply(200, ProtoJson(resp));
}

}  // namespace

std::vector<WebRoute> CohortRoutes() {
  return {{"GET", "/api/v1/groups/{group}/progress", kSupervisors, &GroupProgress},
          {"GET", "/api/v1/groups/{group}/cohort", kSupervisors, &GroupCohort},
          {"GET", "/api/v1/groups/{group}/sessions.csv", kSupervisors, &GroupSessionsCsv},
          {"GET", "/api/v1/trainees/{id}/report", kReaders, &TraineeReport}};
}

}  // namespace ves::server
