#include "station/training/case_run.h"

#include <cmath>
#include <stdexcept>
#include <string>

namespace ves::training {

CaseRun PrepareCaseRun(const v1::ColonCase& colon_case, const v1::EndoscopeSpec& scope,
                       const CaseModelOptions& options, double time_limit_s, double dt_s) {
  if (!(time_limit_s > 0.0)) {
    throw std::invalid_argument("time limit must be > 0 s, got " + std::to_string(time_limit_s));
  }
  CaseRun run;
  run.params = MakeModelParams(colon_case, scope, options);
  if (dt_s != 0.0) {
    run.params.dt_s = dt_s;
    model::ValidateParams(run.params);
  }
  SessionConfig& c = run.config;
  c.case_id = colon_case.id();
  c.case_version = colon_case.version();
  c.difficulty = colon_case.difficulty();
  c.scope = scope;
  c.dt_s = run.params.dt_s;
  c.time_limit_s = time_limit_s;
  c.thresholds = ThresholdsFor(run.params);
  return run;
}

v1::ReplaySetup MakeReplaySetup(const v1::ColonCase& colon_case, const CaseModelOptions& options,
                                double time_limit_s) {
  v1::ReplaySetup setup;
  *setup.mutable_colon_case() = colon_case;
  setup.mutable_colon_case()->clear_mucosa_texture();
  setup.set_segment_count(static_cast<std::uint32_t>(options.segments));
  setup.set_time_limit_s(time_limit_s);
  setup.set_stiff_colon(options.stiff_colon);
  return setup;
}

CaseRun PrepareReplay(const v1::SessionRecord& record) {
  if (!record.has_replay_setup() || record.replay_setup().colon_case().centerline_size() == 0) {
    throw ReplayError("replay: the session record carries no replay_setup (case and model set-up)");
  }
  const v1::ReplaySetup& setup = record.replay_setup();
  CaseModelOptions options;
  options.segments = static_cast<int>(setup.segment_count());
  options.stiff_colon = setup.stiff_colon();
  try {
    CaseRun run = PrepareCaseRun(setup.colon_case(), record.scope(), options, setup.time_limit_s(),
                                 record.input_log().dt_s());
    run.config.operator_kind = record.operator_kind();
    run.config.trainee_id = record.trainee_id();
    return run;
  } catch (const std::invalid_argument& e) {
    throw ReplayError(std::string("replay: the recorded set-up is unusable: ") + e.what());
  }
}

RunResult RunScriptedCase(const v1::ColonCase& colon_case, const v1::EndoscopeSpec& scope,
                          const CaseModelOptions& options, std::string_view operator_kind,
                          double seconds, std::int64_t start_unix_ms, v1::SessionRecord* record,
                          const StepCallback& on_step, double dt_s) {
  CaseRun run = PrepareCaseRun(colon_case, scope, options, seconds, dt_s);
  const RunResult result = RunScriptedSession(run.params, std::move(run.config), operator_kind,
                                              start_unix_ms, record, on_step);
  if (record != nullptr)
    *record->mutable_replay_setup() = MakeReplaySetup(colon_case, options, seconds);
  return result;
}

v1::SessionRecord RecoverSession(const v1::SessionRecord& header,
                                 std::span<const InputSample> inputs) {
  CaseRun run = PrepareReplay(header);
  run.config.station_id = header.station_id();
  run.config.lesson_id = header.lesson_id();
  run.config.case_id = header.case_id();
  run.config.case_version = header.case_version();
  run.config.case_sha256_hex = header.case_sha256_hex();
  SessionRunner runner(run.params, run.config);
  runner.Start(header.start_unix_ms());
  RunInputs(inputs, &runner);
  const auto duration_ms =
      static_cast<std::int64_t>(std::llround(runner.session().metrics().duration_s * 1e3));
  v1::SessionRecord record =
      runner.session().ToRecord(header.uuid(), header.start_unix_ms() + duration_ms);
  *record.mutable_replay_setup() = header.replay_setup();
  return record;
}

RunResult ReplayRecord(const v1::SessionRecord& record, const StepCallback& on_step) {
  const CaseRun run = PrepareReplay(record);
  return Replay(run.params, run.config, record.input_log(), on_step);
}

}  // namespace ves::training
