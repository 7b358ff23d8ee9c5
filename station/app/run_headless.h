#pragma once

#include "station/app/run_options.h"
#include "station/app/run_sync.h"
#include "station/sync/station_paths.h"
#include "station/training/case_run.h"

// `ves-station run --headless` (docs/station-run.md): a scripted operator's
// hand on the simulated VES-IV, on simulated time; frames, the summary, the
// device line and the session file into --out; the record committed to the
// outbox, then uploaded.
namespace ves::station {

// Returns the run's exit status (kExitOk, kExitFailed).
int RunHeadless(const RunOptions& o, const sync::StationPaths& paths, const ObtainedCase& obtained,
                training::CaseRun run);

}  // namespace ves::station
