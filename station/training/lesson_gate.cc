#include "station/training/lesson_gate.h"

#include <google/protobuf/util/message_differencer.h>

#include <time.h>

#include <algorithm>
#include <cstdio>
#include <exception>
#include <stdexcept>

#include "station/training/case_run.h"
#include "station/training/session.h"

namespace ves::training {
namespace {

std::string Num(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3g", v);
  return buf;
}

class Checks {
 public:
  explicit Checks(GateResult* out) : out_(out) {}
  void Rule(bool ok, const std::string& text) {
    out_->checks.push_back(text + (ok ? ": ok" : ": FAILED"));
    if (!ok) failed_ = true;
  }
  bool failed() const { return failed_; }

 private:
  GateResult* out_;
  bool failed_{false};
};

// Rounds away the representation noise of accumulated time (59.99999 s).
constexpr double kTolerance = 1e-6;
// A session that used its whole time limit ends on the last step before it:
// up to one model step (1 ms) short.
constexpr double kFullTimeTolerance_s = 1.5e-3;

struct BudgetExceeded : std::runtime_error {
  using std::runtime_error::runtime_error;
};

double ThreadCpuSeconds() {
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

GateResult Rejected(GateResult so_far, const std::string& why) {
  so_far.checks.push_back("rejected: " + why);
  so_far.passed = false;
  so_far.rejected = true;
  return so_far;
}

// Empty when the log may be decoded and replayed within `budget`.
std::string CheckJudgeBounds(const v1::Lesson& lesson, const v1::InputLog& log,
                             const JudgeBudget& budget) {
  const double dt_s = log.dt_s();
  if (!(dt_s >= kMinJudgedDt_s && dt_s <= kMaxJudgedDt_s)) {
    return "input_log.dt_s " + Num(dt_s) + " is outside [" + Num(kMinJudgedDt_s) + ", " +
           Num(kMaxJudgedDt_s) + "] s";
  }
  std::uint64_t claimed = 0;
  try {
    claimed = std::max(PeekInputSampleCount(log.encoded()), log.sample_count());
  } catch (const InputLogError& error) {
    return error.what();
  }
  const std::uint64_t max_samples = MaxSessionSamples(lesson.time_limit_s(), dt_s);
  if (claimed > max_samples) {
    return "the input log claims " + std::to_string(claimed) + " samples, more than the " +
           std::to_string(max_samples) + " of a " + Num(lesson.time_limit_s()) +
           " s lesson at dt_s " + Num(dt_s);
  }
  if (claimed > budget.memory_bytes / kJudgedBytesPerSample) {
    const double mib = 1.0 / (1 << 20);
    return "judging " + std::to_string(claimed) + " samples takes about " +
           Num(static_cast<double>(claimed * kJudgedBytesPerSample) * mib) +
           " MiB, over the memory budget of " +
           Num(static_cast<double>(budget.memory_bytes) * mib) + " MiB";
  }
  return {};
}

// A limit on the arrival (its time, the scope in) implies the arrival.
bool RequiresCecum(const v1::PassCriteria& p) {
  return p.must_reach_cecum() || p.has_max_time_to_cecum_s() || p.has_max_inserted_at_cecum_m();
}

}  // namespace

std::vector<std::string> DescribePassCriteria(const v1::Lesson& lesson) {
  const v1::PassCriteria& p = lesson.pass();
  std::vector<std::string> out;
  out.push_back("use the whole " + Num(lesson.time_limit_s()) +
                " s unless the cecum is reached (stopping early fails)");
  if (RequiresCecum(p)) out.push_back("reach the cecum");
  if (p.has_max_time_to_cecum_s()) {
    out.push_back("time_to_cecum_s <= " + Num(p.max_time_to_cecum_s()) + " s");
  }
  if (p.has_max_inserted_at_cecum_m()) {
    out.push_back("inserted_at_cecum_m <= " + Num(p.max_inserted_at_cecum_m()) + " m");
  }
  if (p.has_max_pain_s()) out.push_back("pain_s <= " + Num(p.max_pain_s()) + " s");
  if (p.has_max_xray_s()) out.push_back("xray_s <= " + Num(p.max_xray_s()) + " s");
  if (p.has_min_score()) out.push_back("score >= " + Num(p.min_score()));
  if (p.has_max_loop_s()) out.push_back("loop_s <= " + Num(p.max_loop_s()) + " s");
  if (p.has_max_excessive_force_s()) {
    out.push_back("excessive_force_s <= " + Num(p.max_excessive_force_s()) + " s");
  }
  if (p.has_max_damage_events()) {
    out.push_back("damage_events <= " + std::to_string(p.max_damage_events()));
  }
  if (p.has_min_max_tip_arc_m()) {
    out.push_back("max_tip_arc_m >= " + Num(p.min_max_tip_arc_m()) + " m");
  }
  if (p.has_min_mucosa_seen_fraction()) {
    out.push_back("mucosa_seen_fraction >= " + Num(p.min_mucosa_seen_fraction()));
  }
  if (p.has_max_peak_insertion_force_n()) {
    out.push_back("peak_insertion_force_N <= " + Num(p.max_peak_insertion_force_n()) + " N");
  }
  if (!lesson.aids().fluoroscopy_allowed()) out.push_back("no fluoroscopy (xray_s = 0)");
  if (!lesson.aids().wireframe_allowed()) out.push_back("no wireframe view");
  return out;
}

GateResult CheckLessonGate(const v1::Lesson& lesson, const v1::SessionMetrics& m, double score,
                           bool wireframe_used) {
  GateResult out;
  out.score = score;
  Checks c(&out);
  const v1::PassCriteria& p = lesson.pass();
  // A lesson is its whole time limit: cutting it short (an abort, a practice
  // cut) cannot pass a gate that only limits bad events.
  c.Rule(m.completed() || m.duration_s() + kFullTimeTolerance_s >= lesson.time_limit_s(),
         "duration_s " + Num(m.duration_s()) + " >= " + Num(lesson.time_limit_s()) +
             " or cecum reached");
  if (RequiresCecum(p)) {
    c.Rule(m.completed(), std::string("cecum ") + (m.completed() ? "reached" : "not reached"));
  }
  if (p.has_max_inserted_at_cecum_m()) {
    c.Rule(m.completed() && m.inserted_at_cecum_m() <= p.max_inserted_at_cecum_m() + kTolerance,
           "inserted_at_cecum_m " + Num(m.inserted_at_cecum_m()) +
               " <= " + Num(p.max_inserted_at_cecum_m()));
  }
  if (p.has_max_time_to_cecum_s()) {
    c.Rule(m.completed() && m.time_to_cecum_s() <= p.max_time_to_cecum_s() + kTolerance,
           "time_to_cecum_s " + Num(m.time_to_cecum_s()) + " <= " + Num(p.max_time_to_cecum_s()));
  }
  auto at_most = [&](bool has, double value, double limit, const char* name) {
    if (has) c.Rule(value <= limit + kTolerance, std::string(name) + " " + Num(value) + " <= " +
                                                     Num(limit));
  };
  auto at_least = [&](bool has, double value, double limit, const char* name) {
    if (has) c.Rule(value + kTolerance >= limit, std::string(name) + " " + Num(value) + " >= " +
                                                     Num(limit));
  };
  at_most(p.has_max_pain_s(), m.pain_s(), p.max_pain_s(), "pain_s");
  at_most(p.has_max_xray_s(), m.xray_s(), p.max_xray_s(), "xray_s");
  at_least(p.has_min_score(), score, p.min_score(), "score");
  at_most(p.has_max_loop_s(), m.loop_s(), p.max_loop_s(), "loop_s");
  at_most(p.has_max_excessive_force_s(), m.excessive_force_s(), p.max_excessive_force_s(),
          "excessive_force_s");
  at_most(p.has_max_damage_events(), m.damage_events(), p.max_damage_events(), "damage_events");
  at_least(p.has_min_max_tip_arc_m(), m.max_tip_arc_m(), p.min_max_tip_arc_m(), "max_tip_arc_m");
  at_least(p.has_min_mucosa_seen_fraction(), m.mucosa_seen_fraction(),
           p.min_mucosa_seen_fraction(), "mucosa_seen_fraction");
  at_most(p.has_max_peak_insertion_force_n(), m.peak_insertion_force_n(),
          p.max_peak_insertion_force_n(), "peak_insertion_force_N");
  if (!lesson.aids().fluoroscopy_allowed()) {
    c.Rule(m.xray_s() == 0.0, "fluoroscopy not allowed: xray_s " + Num(m.xray_s()) + " = 0");
  }
  if (!lesson.aids().wireframe_allowed()) {
    c.Rule(!wireframe_used, std::string("wireframe not allowed: ") +
                                (wireframe_used ? "used" : "not used"));
  }
  out.passed = !c.failed();
  return out;
}

GateResult JudgeLessonSession(const v1::Lesson& lesson, const v1::ColonCase& lesson_case,
                              const v1::SessionRecord& record, const std::atomic<bool>* cancel,
                              const JudgeBudget& budget, const StepCallback& observe,
                              std::optional<RunResult>* replayed) {
  GateResult refused;
  Checks c(&refused);
  c.Rule(record.lesson_id() == lesson.lesson_id(),
         "lesson_id '" + record.lesson_id() + "' = '" + lesson.lesson_id() + "'");
  c.Rule(record.case_sha256_hex() == lesson.case_ref().payload_sha256_hex(),
         "case sha256 " + record.case_sha256_hex().substr(0, 12) + " = lesson's " +
             lesson.case_ref().payload_sha256_hex().substr(0, 12));
  c.Rule(google::protobuf::util::MessageDifferencer::Equals(record.scope(), lesson.scope()),
         "scope '" + record.scope().id() + "' = lesson's '" + lesson.scope().id() + "'");
  const double limit_s = record.replay_setup().time_limit_s();
  c.Rule(limit_s > 0.0 && limit_s <= lesson.time_limit_s() + kTolerance,
         "time limit " + Num(limit_s) + " s <= " + Num(lesson.time_limit_s()) + " s");
  if (c.failed()) return refused;

  // Bounded before anything is decoded or run: the step, the sample count the
  // log's header claims against the lesson's time limit, the memory it takes.
  const std::string why_not = CheckJudgeBounds(lesson, record.input_log(), budget);
  if (!why_not.empty()) return Rejected(std::move(refused), why_not);
  const double cpu_budget_s = budget.cpu_base_s + budget.cpu_per_limit_s * lesson.time_limit_s();
  const double cpu_start_s = ThreadCpuSeconds();
  std::uint64_t steps = 0;

  // The authoritative run: the lesson's case, scope and time limit, the
  // record's inputs. Nothing the record claims about its results is read.
  v1::SessionRecord rerun = record;
  *rerun.mutable_replay_setup() = MakeReplaySetup(lesson_case, {}, lesson.time_limit_s());
  *rerun.mutable_scope() = lesson.scope();
  bool wireframe_used = false;
  RunResult result;
  try {
    result = ReplayRecord(rerun, [&](const InputSample& input, const SessionRunner& runner) {
      if (input.view_mode == ViewMode::kWireframe) wireframe_used = true;
      if (observe) observe(input, runner);
      if (cancel != nullptr && cancel->load(std::memory_order_relaxed)) {
        throw JudgeCancelled("lesson judge: replay cancelled");
      }
      // The clock read costs ~100 ns: every 256 steps is plenty.
      if ((++steps & 0xff) == 0 && ThreadCpuSeconds() - cpu_start_s > cpu_budget_s) {
        throw BudgetExceeded("the replay used more than its " + Num(cpu_budget_s) +
                             " s CPU budget after " + std::to_string(steps) + " steps");
      }
    });
  } catch (const JudgeCancelled&) {
    throw;
  } catch (const BudgetExceeded& over) {
    return Rejected(std::move(refused), over.what());
  } catch (const std::exception& error) {
    c.Rule(false, std::string("replay: ") + error.what());
    return refused;
  }
  if (replayed != nullptr) *replayed = result;
  GateResult out = CheckLessonGate(lesson, ToProto(result.metrics), result.score, wireframe_used);
  out.checks.insert(out.checks.begin(), refused.checks.begin(), refused.checks.end());
  if (result.diverged) {
    out.checks.push_back("replay diverged: FAILED");
    out.passed = false;
  }
  return out;
}

}  // namespace ves::training
