#pragma once

#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "station/haptics/can_bus.h"
#include "station/sync/server_client.h"
#include "station/training/case_run.h"
#include "station/training/replay.h"
#include "station/training/sitting.h"
#include "ves/v1/case.pb.h"
#include "ves/v1/lesson.pb.h"
#include "ves/v1/session.pb.h"

// `ves-station run` without --headless: the three windows (station/ui) on
// this thread at display rate; the model in the 1 kHz haptic loop (coupled
// mode) behind the VES-IV driver; with the simulated device, the keyboard
// moves the simulated hand (docs/station-run.md).
namespace ves::station {

// A session that ran (went in past the anus): its record and its result
// (what the summary line and the debrief show).
struct EndedSession {
  ves::v1::SessionRecord record;
  training::RunResult result;
};

struct InteractiveResult {
  // Every session that ran at least one step and was not handed to the
  // caller's SessionEndedCallback, oldest first: each "repeat" finishes the
  // current one (aborted if still running) and starts another. A session
  // that never went in past the anus did not start: it is none of them.
  std::vector<EndedSession> records;
  training::RunResult result;  // of the last one
  std::string device_report;   // DeviceReportLine of the run
  std::string live_report;     // "live: ..." when it streamed; "" otherwise
  // Set when the trainee chose another case or scope on the panel and pressed
  // "repeat": indices into InteractiveChoices; the caller starts that run.
  std::optional<int> next_case;
  std::optional<int> next_scope;
};

// What the panel offers (paper §4.4, "choose case and scope"); a lesson run
// offers none (the lesson fixes both).
struct InteractiveChoices {
  std::vector<std::string> case_names;   // the cached cases
  std::vector<std::string> scope_names;
  int current_case{0};                   // what this run uses
  int current_scope{0};
};

struct InteractiveDevice {
  // A SocketCAN bus with the real VES-IV on it; empty: the simulated device
  // on a socketpair, its hand moved by the keyboard.
  std::optional<haptics::CanBus> can_bus;
  std::string can_log;  // candump log of every frame; empty: none
  // A game controller's evdev device moving the simulated hand with the
  // keyboard (ui/gamepad.h); empty: none.
  std::string gamepad;
};

// Live proctoring of the run's sessions (docs/station-run.md): each session
// streams to `server` while it runs; nullopt (no --server, --no-live): none.
struct InteractiveLiveTarget {
  std::optional<sync::ServerEndpoint> server;
  std::string case_id;
  uint32_t case_version{0};
};

// Called on the UI thread with each session's record as soon as the session
// ends (cecum, time limit, or a repeat), with the station's health as it
// ended, so that the caller can commit it at once.
using SessionEndedCallback = std::function<void(EndedSession)>;

// Runs until the trainee quits (q / Esc) or the time limit of a session
// passes and the trainee quits. Throws std::runtime_error when there is no
// display or the device does not come up, render::RenderError when the views
// cannot render.
// `lesson_aids` (a lesson run, docs/lessons.md): an aid that is off stays off
// whatever the keys and panel ask — the fluoroscopy window is not rendered and
// the wireframe view falls back to flat polygons.
// `choices`: the panel's case and scope lists; choosing another entry and
// pressing "repeat" ends this run with next_case/next_scope set.
// `live`: where the sessions stream (null: nowhere).
// `on_session_ended`: each record as its session ends, the one running at
// the quit included (empty: they are all returned in the result).
// `journal_dir`: where each running session's inputs are journaled
// (sync::SessionJournalWriter; empty: nowhere), so that a station that dies
// mid-session loses at most about a second. The caller deletes a journal
// once its session's record is safely stored; with `on_session_ended` each
// journal stays locked (sync::JournalInUse) until that call returns, so a
// `ves-station sync` meanwhile cannot recover the session a second time.
// `sitting`: the trainee's sitting so far, which `on_session_ended` adds each
// session to; the debrief on the screen names its best and last (null: this
// run's sessions only).
InteractiveResult RunInteractive(const training::CaseRun& run,
                                 const ves::v1::ColonCase& colon_case, double time_limit_s,
                                 InteractiveDevice device,
                                 const ves::v1::LessonAids* lesson_aids = nullptr,
                                 const InteractiveChoices* choices = nullptr,
                                 const InteractiveLiveTarget* live = nullptr,
                                 const SessionEndedCallback& on_session_ended = {},
                                 const std::filesystem::path& journal_dir = {},
                                 const training::Sitting* sitting = nullptr);

}  // namespace ves::station
