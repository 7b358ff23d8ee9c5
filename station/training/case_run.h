#pragma once

#include <cstdint>
#include <span>
#include <string_view>

#include "station/training/case_model.h"
#include "station/training/replay.h"
#include "ves/v1/case.pb.h"
#include "ves/v1/endoscope.pb.h"
#include "ves/v1/session.pb.h"

namespace ves::training {

// Everything a run on a case needs: the model's parameters and the session's
// rules (cecum from the case's regions, difficulty from the case).
struct CaseRun {
  model::ModelParams params;
  SessionConfig config;
};

// Throws std::invalid_argument for an unusable case, scope, time limit or
// time step (dt_s 0: the model's default).
CaseRun PrepareCaseRun(const v1::ColonCase& colon_case, const v1::EndoscopeSpec& scope,
                       const CaseModelOptions& options, double time_limit_s, double dt_s = 0.0);

// What replay needs besides the input log (the case without its texture).
v1::ReplaySetup MakeReplaySetup(const v1::ColonCase& colon_case, const CaseModelOptions& options,
                                double time_limit_s);

// Rebuilds the run of a recorded session from its replay_setup, scope and
// the input log's dt.
// Throws ReplayError when the record has no usable replay_setup.
CaseRun PrepareReplay(const v1::SessionRecord& record);

// A scripted operator on a case: the result and the record (with replay_setup).
RunResult RunScriptedCase(const v1::ColonCase& colon_case, const v1::EndoscopeSpec& scope,
                          const CaseModelOptions& options, std::string_view operator_kind,
                          double seconds, std::int64_t start_unix_ms, v1::SessionRecord* record,
                          const StepCallback& on_step = {}, double dt_s = 0.0);

// The record of a session the station could not record itself (it stopped
// mid-session): re-run from its journal's header (RecordHeader with the
// replay_setup) and the inputs that reached the disk; aborted when they end
// while it runs. Throws ReplayError for an unusable header, inputs out of
// sequence, or inputs past the session's end (its time limit included:
// RunInputs).
v1::SessionRecord RecoverSession(const v1::SessionRecord& header,
                                 std::span<const InputSample> inputs);

// Re-runs a recorded session from its log alone (PrepareReplay + Replay).
RunResult ReplayRecord(const v1::SessionRecord& record, const StepCallback& on_step = {});

}  // namespace ves::training
