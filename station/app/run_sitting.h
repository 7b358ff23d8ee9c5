#pragma once

#include "station/app/run_interactive.h"
#include "station/app/run_options.h"
#include "station/app/run_sync.h"
#include "station/sync/station_paths.h"
#include "station/training/case_run.h"

// `ves-station run` without --headless (docs/station-run.md, "A sitting"):
// the trainee's sitting, one interactive run after another across the case
// and scope switches of the panel, each session committed to the outbox as
// it ends; at the quit the upload, the verdicts and the sitting's report.
namespace ves::station {

// The device of an interactive run: SocketCAN when --device can:IFACE (throws
// when the interface cannot be opened), else the simulated one.
InteractiveDevice OpenInteractiveDevice(const RunOptions& o);

// Returns the run's exit status (kExitOk, kExitFailed, kExitUsage).
int RunSitting(const RunOptions& o, const sync::StationPaths& paths, ObtainedCase obtained,
               training::CaseRun run, InteractiveDevice device);

}  // namespace ves::station
