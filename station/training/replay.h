#pragma once

#include <cstdint>
#include <functional>
#include <span>
#include <stdexcept>
#include <string_view>
#include <vector>

#include "station/model/model.h"
#include "station/training/debrief.h"
#include "station/training/session_runner.h"
#include "ves/v1/session.pb.h"

namespace ves::training {

class ScriptedOperator;  // scripted_operator.h

// Thresholds for a model colon: the cecum begins at the first segment point
// labelled cecum (the deepest point minus 5 cm when no point is); the rest
// are the documented defaults (docs/scoring.md).
MetricThresholds ThresholdsFor(const model::ModelParams& params);

// Refusal of a log that cannot be the record of a session on these params.
class ReplayError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct RunResult {
  Outcome outcome{Outcome::kNone};
  Metrics metrics;
  std::vector<Event> events;
  double score{0.0};
  std::uint64_t steps{0};
  bool diverged{false};
  std::string deepest_region;  // the region at metrics.max_tip_arc_m ("sigmoid", ...)
  Debrief debrief;             // the score split into its weighed parts, with places

  bool operator==(const RunResult&) const = default;
};

// The result of a runner's session as it stands (outcome, metrics, events,
// score, steps).
RunResult ResultOf(const SessionRunner& runner);

// Called after every step with the runner (model state, output, observation).
using StepCallback = std::function<void(const InputSample&, const SessionRunner&)>;

// Runs a scripted operator ("novice" or "expert") from the model's initial
// state until the cecum is reached or config.time_limit_s passes. Fills
// `record` (a fresh UUID v4, start_unix_ms as given, end = start + duration)
// when not null.
RunResult RunScriptedSession(const model::ModelParams& params, SessionConfig config,
                             std::string_view operator_kind, std::int64_t start_unix_ms,
                             v1::SessionRecord* record, const StepCallback& on_step = {});
// The same with an operator of the caller's (`operator_kind` names it in
// the record), e.g. a novice with another push.
RunResult RunScriptedSession(const model::ModelParams& params, SessionConfig config,
                             ScriptedOperator& op, std::string_view operator_kind,
                             std::int64_t start_unix_ms, v1::SessionRecord* record,
                             const StepCallback& on_step = {});

// Re-runs the model from a logged input sequence and recomputes every metric.
// Deterministic: the same build gives bit-identical results. A log that ends
// while the session still runs is an aborted session. Throws InputLogError
// for a bad log and ReplayError for samples after the session finished or
// ticks out of sequence.
RunResult Replay(const model::ModelParams& params, const SessionConfig& config,
                 const v1::InputLog& log, const StepCallback& on_step = {});

// Replay's loop: steps a started runner through the inputs (ticks in
// sequence from 0, none after the session finished: ReplayError), then
// aborts the session if it still runs.
void RunInputs(std::span<const InputSample> inputs, SessionRunner* runner,
               const StepCallback& on_step = {});

// One line of key=value pairs for people and scripts, the same from `run`,
// `sim --operator` and `replay` (docs/scoring.md): what did not happen is
// `-`, times to 0.1 s, lengths to 1 mm, forces to 0.01 N, the score with its
// scale (`score=34.2/100`).
std::string SummaryLine(const RunResult& result);

}  // namespace ves::training
