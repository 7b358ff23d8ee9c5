#include "station/training/replay.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

#include "station/training/case_model.h"
#include "station/training/scripted_operator.h"
#include "station/training/uuid.h"

namespace ves::training {

RunResult ResultOf(const SessionRunner& runner) {
  const Session& s = runner.session();
  RunResult r;
  r.outcome = s.outcome();
  r.metrics = s.metrics();
  r.events = s.accumulator().Events();
  r.score = s.score();
  r.steps = s.steps();
  r.diverged = runner.diverged();
  r.deepest_region = RegionNameAt(runner.params().colon, r.metrics.max_tip_arc_m);
  const SessionConfig& config = s.config();
  r.debrief = CalcDebrief(r.metrics, r.events, config.difficulty, config.thresholds.cecum_arc_m,
                          config.score, [&runner](double arc_m) {
                            return RegionNameAt(runner.params().colon, arc_m);
                          });
  return r;
}

MetricThresholds ThresholdsFor(const model::ModelParams& params) {
  MetricThresholds t;
  const auto& pts = params.colon.points;
  t.cecum_arc_m = std::max(pts.back().arc_m - 0.05, 0.5 * pts.back().arc_m);
  for (const auto& p : pts) {
    if (p.region == model::Region::kCecum) {
      t.cecum_arc_m = p.arc_m;
      break;
    }
  }
  return t;
}

RunResult RunScriptedSession(const model::ModelParams& params, SessionConfig config,
                             std::string_view operator_kind, std::int64_t start_unix_ms,
                             v1::SessionRecord* record, const StepCallback& on_step) {
  const auto op = MakeScriptedOperator(operator_kind, params.dt_s);
  return RunScriptedSession(params, std::move(config), *op, operator_kind, start_unix_ms, record,
                            on_step);
}

RunResult RunScriptedSession(const model::ModelParams& params, SessionConfig config,
                             ScriptedOperator& op, std::string_view operator_kind,
                             std::int64_t start_unix_ms, v1::SessionRecord* record,
                             const StepCallback& on_step) {
  config.operator_kind = std::string(operator_kind);
  SessionRunner runner(params, std::move(config));
  runner.Start(start_unix_ms);
  Perception perception = Perceive(params, runner.state(), runner.output());
  while (runner.session().state() == SessionState::kRunning) {
    const InputSample input = op.Act(perception);
    runner.Step(input);
    if (on_step && !runner.diverged()) on_step(runner.session().inputs().back(), runner);
    perception = Perceive(params, runner.state(), runner.output());
  }
  const RunResult result = ResultOf(runner);
  if (record != nullptr) {
    const auto duration_ms =
        static_cast<std::int64_t>(std::llround(result.metrics.duration_s * 1e3));
    *record = runner.session().ToRecord(NewUuidV4(), start_unix_ms + duration_ms);
  }
  return result;
}

RunResult Replay(const model::ModelParams& params, const SessionConfig& config,
                 const v1::InputLog& log, const StepCallback& on_step) {
  if (log.dt_s() != params.dt_s) {
    throw ReplayError("replay: log dt_s " + std::to_string(log.dt_s()) +
                      " differs from the model's " + std::to_string(params.dt_s));
  }
  // Refused before decoding: a header claiming more samples than the time
  // limit allows must not make the decoder allocate them.
  const std::uint64_t max_samples = MaxSessionSamples(config.time_limit_s, params.dt_s);
  const std::uint64_t claimed = std::max(PeekInputSampleCount(log.encoded()), log.sample_count());
  if (claimed > max_samples) {
    throw ReplayError("replay: the log claims " + std::to_string(claimed) +
                      " samples, more than the " + std::to_string(max_samples) + " a " +
                      std::to_string(config.time_limit_s) + " s session at dt_s " +
                      std::to_string(params.dt_s) + " can hold");
  }
  const std::vector<InputSample> inputs = DecodeInputLog(log);
  SessionRunner runner(params, config);
  runner.Start(0);
  RunInputs(inputs, &runner, on_step);
  return ResultOf(runner);
}

void RunInputs(std::span<const InputSample> inputs, SessionRunner* runner,
               const StepCallback& on_step) {
  for (std::size_t i = 0; i < inputs.size(); ++i) {
    if (inputs[i].tick != i) {
      throw ReplayError("replay: sample " + std::to_string(i) + " has tick " +
                        std::to_string(inputs[i].tick));
    }
    if (runner->session().state() != SessionState::kRunning) {
      throw ReplayError("replay: the log continues " + std::to_string(inputs.size() - i) +
                        " samples after the session finished");
    }
    runner->Step(inputs[i]);
    if (on_step && !runner->diverged()) on_step(runner->session().inputs().back(), *runner);
  }
  if (runner->session().state() == SessionState::kRunning) runner->session().Abort();
}

std::string SummaryLine(const RunResult& r) {
  const Metrics& m = r.metrics;
  char time_to_cecum[32] = "-";
  char inserted_at_cecum[32] = "-";
  if (m.completed) {
    std::snprintf(time_to_cecum, sizeof(time_to_cecum), "%.1f", m.time_to_cecum_s);
    std::snprintf(inserted_at_cecum, sizeof(inserted_at_cecum), "%.3f", m.inserted_at_cecum_m);
  }
  char line[512];
  std::snprintf(line, sizeof(line),
                "outcome=%s time_to_cecum_s=%s inserted_at_cecum_m=%s deepest_tip_arc_m=%.3f "
                "deepest_region=%s pain_s=%.1f loop_s=%.1f peak_force_N=%.2f xray_s=%.1f "
                "press_llq_s=%.1f press_mid_s=%.1f position_changes=%u score=%.1f/100",
                OutcomeName(r.outcome), time_to_cecum, inserted_at_cecum, m.max_tip_arc_m,
                r.deepest_region.empty() ? "-" : r.deepest_region.c_str(), m.pain_s, m.loop_s,
                m.peak_insertion_force_N, m.xray_s, m.press_llq_s, m.press_mid_s,
                static_cast<unsigned>(m.position_changes), r.score);
  return line;
}

}  // namespace ves::training
