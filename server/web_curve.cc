// The learning-curve route of the HTTP API (docs/web.md, "Learning curve"):
// a trainee's attempts per case and per lesson, with the lessons' pass lines,
// the scripted expert's band and the group's median score per attempt. The
// rules and audit row of Trainees.GetLearningCurve; the trainee's sessions
// are read from the store once.
#include <nlohmann/json.hpp>

#include "server/pipeline.h"
#include "server/web_cohort.h"
#include "server/web_reply.h"
#include "server/web_routes.h"
#include "ves/v1/lesson.pb.h"

namespace ves::server {

using grpc::Status;
using grpc::StatusCode;
using nlohmann::json;

namespace {

struct Point {
  std::string uuid, case_id, lesson_id;
  int64_t start = 0;
  double score = 0, time_to_cecum_s = 0, pain_s = 0, loop_s = 0;
  bool completed = false;
};

// The trainee's sessions as points, oldest first. A row stored before the
// session rows kept loop time has it in its record only.
std::vector<Point> PointsOf(patient_db::Store& store,
                            const std::vector<patient_db::SessionRow>& rows) {
  std::vector<Point> points;
  for (const auto& r : rows) {
    Point p{r.uuid,   r.case_id, r.lesson_id, r.start_unix_ms, r.score, r.time_to_cecum_s,
            r.pain_s, 0,         r.completed};
    if (r.loop_s >= 0) {
      p.loop_s = r.loop_s;
    } else {
      auto full = store.GetSession(r.uuid);
      v1::SessionRecord rec;
      if (full.ok() && rec.ParseFromString(full.value.body)) p.loop_s = rec.metrics().loop_s();
    }
    points.push_back(std::move(p));
  }
  return points;
}

// Score per attempt of each case, over the members of the trainee's group
// (the trainee's own rows already read: `mine`).
using GroupScores = std::map<std::string, std::map<int, std::vector<double>>>;
GroupScores GroupScoresOf(patient_db::Store& store, const patient_db::TraineeRow& trainee,
                          const std::string& group, const std::vector<Point>& mine) {
  GroupScores scores;
  if (group.empty()) return scores;
  auto members = store.ListGroupTrainees(trainee.institution, group);
  for (const std::string& m : members.ok() ? members.value : std::vector<std::string>{}) {
    std::vector<std::pair<std::string, double>> runs;  // case, score; oldest first
    if (m == trainee.trainee_id) {
      for (const Point& p : mine) runs.emplace_back(p.case_id, p.score);
    } else {
      auto rows = store.ListSessions(m, "");
      if (!rows.ok()) continue;
      for (const auto& r : rows.value) runs.emplace_back(r.case_id, r.score);
    }
    std::map<std::string, int> attempt;
    for (const auto& [case_id, score] : runs) scores[case_id][++attempt[case_id]].push_back(score);
  }
  return scores;
}

json CurveJson(const std::vector<const Point*>& points) {
  json a = json::array();
  int n = 0;
  for (const Point* p : points) {
    a.push_back({{"attempt", ++n},
                 {"uuid", p->uuid},
                 {"case_id", p->case_id},
                 {"start_unix_ms", p->start},
                 {"score", p->score},
                 {"completed", p->completed},
                 // Null when the cecum was not reached: no time to plot.
                 {"time_to_cecum_s", p->completed ? json(p->time_to_cecum_s) : json(nullptr)},
                 {"pain_s", p->pain_s},
                 {"loop_s", p->loop_s}});
  }
  return a;
}

// A lesson's pass line from its curriculum, and its case's expert band.
void LessonLines(patient_db::Store& store, const std::string& institution,
                 const std::string& lesson_id, json* pass, json* band) {
  auto curriculum_id = store.FindLessonCurriculum(lesson_id);
  if (!curriculum_id.ok()) return;
  auto curriculum = store.GetCurriculum(curriculum_id.value);
  v1::Curriculum c;
  if (!curriculum.ok() || !c.ParseFromString(curriculum.value.body)) return;
  for (const auto& l : c.lessons()) {
    if (l.lesson_id() != lesson_id) continue;
    if (l.pass().has_min_score()) (*pass)["score"] = l.pass().min_score();
    if (l.pass().has_max_time_to_cecum_s())
      (*pass)["time_to_cecum_s"] = l.pass().max_time_to_cecum_s();
    if (l.pass().has_max_pain_s()) (*pass)["pain_s"] = l.pass().max_pain_s();
    if (l.pass().has_max_loop_s()) (*pass)["loop_s"] = l.pass().max_loop_s();
    (*pass)["title"] = l.title();
    *band = ExpertBandJson(store, institution, l.case_ref().case_id());
  }
}

// GET trainees/{id}/curve.
HttpReply LearningCurve(WebCall& call) {
  const std::string& id = call.Param("id");
  v1::LearningCurveRequest req;
  req.set_trainee_id(id);
  Status s = call.Admit(req);
  if (!s.ok()) return ErrorOf(s);
  patient_db::Store& store = *call.deps.store;
  static const CallSpec spec{"trainee.curve", kReaders, "read the learning curve"};
  patient_db::TraineeRow trainee;
  std::vector<Point> mine;
  s = RunCall(call.deps, call.who, spec, id, [&]() -> Status {
    auto found = store.GetTrainee(id);
    if (!found.ok()) return ToGrpcStatus(found.status);
    // Another institution's trainee (or, for a trainee, anyone else)
    // answers as an absent one: its existence is not told.
    if (!RequireTraineeReader(call.who, found.value, "read the learning curve").ok()) {
      return Status(StatusCode::NOT_FOUND, "no trainee '" + id + "'");
    }
    trainee = std::move(found.value);
    auto rows = store.ListSessions(trainee.trainee_id, "");
    if (!rows.ok()) return ToGrpcStatus(rows.status);
    mine = PointsOf(store, rows.value);
    return Status::OK;
  });
  if (!s.ok()) return ErrorOf(s);
  auto group = store.GetTraineeGroup(trainee.trainee_id);
  const std::string group_name = group.ok() ? group.value : "";
  GroupScores group_scores = GroupScoresOf(store, trainee, group_name, mine);
  std::map<std::string, std::vector<const Point*>> by_case, by_lesson;
  for (const Point& p : mine) {
    by_case[p.case_id].push_back(&p);
    if (!p.lesson_id.empty()) by_lesson[p.lesson_id].push_back(&p);
  }
  json cases = json::array();
  for (auto& [case_id, points] : by_case) {
    json median = json::array();
    for (auto& [attempt, scores] : group_scores[case_id]) {
      median.push_back({{"attempt", attempt}, {"score", MedianOf(scores)}});
    }
    cases.push_back({{"case_id", case_id},
                     {"points", CurveJson(points)},
                     {"group_median", median},
                     {"expert_band", ExpertBandJson(store, trainee.institution, case_id)}});
  }
  json lessons = json::array();
  for (auto& [lesson_id, points] : by_lesson) {
    json pass = json::object();
    json band = nullptr;  // the scripted expert's runs of the lesson's case
    LessonLines(store, trainee.institution, lesson_id, &pass, &band);
    lessons.push_back({{"lesson_id", lesson_id},
                       {"points", CurveJson(points)},
                       {"pass_line", pass},
                       {"expert_band", band}});
  }
  return JsonReply(200, {{"trainee_id", trainee.trainee_id},
                         {"group", group_name},
                         {"cases", cases},
                         {"lessons", lessons}});
}

}  // namespace

std::vector<WebRoute> CurveRoutes() {
  return {{"GET", "/api/v1/trainees/{id}/curve", kReaders, &LearningCurve}};
}

}  // namespace ves::server
