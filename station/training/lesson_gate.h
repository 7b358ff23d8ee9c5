#pragma once

#include <atomic>
#include <stdexcept>
#include <string>
#include <vector>

#include "station/training/replay.h"
#include "ves/v1/case.pb.h"
#include "ves/v1/lesson.pb.h"
#include "ves/v1/session.pb.h"

// A lesson's proficiency gate (docs/lessons.md): its pass criteria checked on
// a session's metrics, and the server's judge, which re-runs the session from
// its input log on the lesson's own case and scope and checks the aids and
// criteria on what the replay computed — never on the metrics the record
// claims. Lives in training because the station (its local verdict) and the
// server (the authoritative one) must judge the same way.
namespace ves::training {

struct GateResult {
  bool passed{false};
  double score{0.0};                // the judged run's score
  std::vector<std::string> checks;  // one line per rule: "pain_s 0.4 <= 10: ok" / "...: FAILED"
};

// One line per criterion, for the trainee before the start ("pain_s <= 10 s").
std::vector<std::string> DescribePassCriteria(const v1::Lesson& lesson);

// The criteria on metrics and score (no replay): the station's local verdict.
// A fluoroscopy-free lesson also fails on any xray_s > 0 and a wireframe-free
// one when `wireframe_used`.
GateResult CheckLessonGate(const v1::Lesson& lesson, const v1::SessionMetrics& metrics,
                           double score, bool wireframe_used);

// The server's judge: the record must name this lesson, carry the lesson's
// case hash and scope and a time limit no longer than the lesson's; then it is
// replayed on `lesson_case` (the case the hash names, as the server stores it)
// with the lesson's scope and time limit, and CheckLessonGate runs on the
// replay's metrics, with wireframe use read from the replayed inputs. A log
// that cannot be replayed fails with the reason. Costs about 1/25 of the
// session's simulated time in CPU (docs/lessons.md). When `cancel` becomes true
// the replay stops and JudgeCancelled is thrown (no verdict: judge it later).
GateResult JudgeLessonSession(const v1::Lesson& lesson, const v1::ColonCase& lesson_case,
                              const v1::SessionRecord& record,
                              const std::atomic<bool>* cancel = nullptr);

class JudgeCancelled : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

}  // namespace ves::training
