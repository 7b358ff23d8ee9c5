#pragma once

#include <atomic>
#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "station/training/input_log.h"
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
  // The judge refused to replay the record at all (over a budget, an input
  // log that cannot belong to the lesson): a final verdict, never judged again.
  bool rejected{false};
};

// What judging one session may cost (docs/lessons.md, "The judge's budgets").
// Both are checked before the input log is decoded where they can be: its
// sample count (from the log's header) against the lesson's time limit and
// the memory decoding it takes; the CPU time while the replay runs.
struct JudgeBudget {
  double cpu_base_s{60.0};           // CPU seconds of the replay: base + ...
  double cpu_per_limit_s{0.5};       // ... this much per second of the lesson's time limit
  std::uint64_t memory_bytes{std::uint64_t{1} << 30};  // decoded log and its copy in the run
};

// Model steps a judged log may use (the station runs at 1 kHz; replay
// re-runs at the log's own step, so the step is bounded too).
inline constexpr double kMinJudgedDt_s = 1e-4;
inline constexpr double kMaxJudgedDt_s = 1e-2;
// Memory one logged sample takes while judged: decoded, held again by the
// replayed session, and its worst-case raw varints.
inline constexpr std::uint64_t kJudgedBytesPerSample = 2 * sizeof(InputSample) + 9 * 10;

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
// A record over `budget` (or whose log claims more samples than the lesson's
// time limit allows, or has a step outside [kMinJudgedDt_s, kMaxJudgedDt_s])
// is refused before decoding or stopped mid-replay: `rejected`, not passed,
// with the reason in `checks`.
// `observe`, when set, is called after every replayed step (the server
// records the session page's series from it, so the session is replayed
// once); `replayed`, when not null, gets the replay's result when it ran to
// its end.
GateResult JudgeLessonSession(const v1::Lesson& lesson, const v1::ColonCase& lesson_case,
                              const v1::SessionRecord& record,
                              const std::atomic<bool>* cancel = nullptr,
                              const JudgeBudget& budget = {}, const StepCallback& observe = {},
                              std::optional<RunResult>* replayed = nullptr);

class JudgeCancelled : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

}  // namespace ves::training
