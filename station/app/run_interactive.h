#pragma once

#include <vector>

#include "station/training/case_run.h"
#include "ves/v1/case.pb.h"
#include "ves/v1/session.pb.h"

// `ves-station run` without --headless: the three windows (station/ui) on
// this thread at display rate, the model on its own thread at 1 kHz driven by
// the keyboard's simulated hand (docs/station-run.md).
namespace ves::station {

struct InteractiveResult {
  // Every session that ran at least one step, oldest first: each "repeat"
  // finishes the current one (aborted if still running) and starts another.
  std::vector<ves::v1::SessionRecord> records;
  training::RunResult result;  // of the last one
};

// Runs until the trainee quits (q / Esc) or the time limit of a session
// passes and the trainee quits. Throws std::runtime_error when there is no
// display, render::RenderError when the views cannot render.
InteractiveResult RunInteractive(const training::CaseRun& run,
                                 const ves::v1::ColonCase& colon_case, double time_limit_s);

}  // namespace ves::station
