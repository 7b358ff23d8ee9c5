#pragma once

#include <optional>
#include <string>
#include <vector>

#include "station/haptics/can_bus.h"
#include "station/training/case_run.h"
#include "ves/v1/case.pb.h"
#include "ves/v1/lesson.pb.h"
#include "ves/v1/session.pb.h"

// `ves-station run` without --headless: the three windows (station/ui) on
// this thread at display rate; the model in the 1 kHz haptic loop (coupled
// mode) behind the VES-IV driver; with the simulated device, the keyboard
// moves the simulated hand (docs/station-run.md).
namespace ves::station {

struct InteractiveResult {
  // Every session that ran at least one step, oldest first: each "repeat"
  // finishes the current one (aborted if still running) and starts another.
  std::vector<ves::v1::SessionRecord> records;
  training::RunResult result;  // of the last one
  std::string device_report;   // DeviceReportLine of the run
};

struct InteractiveDevice {
  // A SocketCAN bus with the real VES-IV on it; empty: the simulated device
  // on a socketpair, its hand moved by the keyboard.
  std::optional<haptics::CanBus> can_bus;
  std::string can_log;  // candump log of every frame; empty: none
};

// Runs until the trainee quits (q / Esc) or the time limit of a session
// passes and the trainee quits. Throws std::runtime_error when there is no
// display or the device does not come up, render::RenderError when the views
// cannot render.
// `lesson_aids` (a lesson run, docs/lessons.md): an aid that is off stays off
// whatever the keys and panel ask — the fluoroscopy window is not rendered and
// the wireframe view falls back to flat polygons.
InteractiveResult RunInteractive(const training::CaseRun& run,
                                 const ves::v1::ColonCase& colon_case, double time_limit_s,
                                 InteractiveDevice device,
                                 const ves::v1::LessonAids* lesson_aids = nullptr);

}  // namespace ves::station
