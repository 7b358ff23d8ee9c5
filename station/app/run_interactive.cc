#include "station/app/run_interactive.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <functional>
#include <iostream>
#include <memory>
#include <mutex>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "patient_db/case_geometry.h"
#include "patient_db/case_regions.h"
#include "station/app/coupled_loop.h"
#include "station/app/haptic_session.h"
#include "station/app/interactive_rig.h"
#include "station/app/journal_keeper.h"
#include "station/app/live_publish.h"
#include "station/app/run_views.h"
#include "station/haptics/seqlock.h"
#include "station/render/model_scene.h"
#include "station/ui/gamepad.h"
#include "station/ui/training_screen.h"
#include "station/ui/training_window.h"

namespace ves::station {
namespace {

// The keys' insertion target leads the scope by at most two key steps: a
// held key against a blocked scope does not wind up a push that goes on
// after the key is released.
constexpr double kKeyLead_m = 0.010;
// The screen is shown at most at a display's refresh rate, and at 10 Hz
// once nothing has moved for a second (a session over, the trainee reading
// the results: the force gauge still moves). The views are rendered only
// when the model published a new state or a view's controls changed. An
// idle screen took a whole core redrawing the same picture
// (docs/station-ui.md, "CPU").
constexpr std::chrono::steady_clock::duration kScreenPeriod = ui::kRunningScreenPeriod;
constexpr std::chrono::steady_clock::duration kIdleScreenPeriod = std::chrono::milliseconds(100);
constexpr std::chrono::steady_clock::duration kIdleAfter = std::chrono::seconds(1);

// For people: "cecum reached", "time limit reached", "aborted".
std::string OutcomeText(training::Outcome outcome) {
  switch (outcome) {
    case training::Outcome::kCecumReached: return "cecum reached";
    case training::Outcome::kTimedOut: return "time limit reached";
    case training::Outcome::kAborted: return "aborted";
    case training::Outcome::kNone: break;
  }
  return "-";
}

// The device line of the screen: force feedback on, fading in, paused by a
// transient fault (clears by itself) or in the safe state (r re-arms).
void DescribeDevice(const haptics::HapticSnapshot& snapshot, const std::string& label,
                    ui::ScreenModel* screen) {
  const haptics::SafetyFault fault = snapshot.fault;
  if (fault == haptics::SafetyFault::kNone) {
    screen->device_status =
        snapshot.output_scale < 1.0 ? ui::DeviceStatus::kRecovering : ui::DeviceStatus::kOk;
    screen->device_text = label + (snapshot.output_scale < 1.0 ? ", force fading back in"
                                                               : ", force feedback on");
  } else if (haptics::IsTransient(fault)) {
    screen->device_status = ui::DeviceStatus::kRecovering;
    screen->device_text = label + ", force paused: " + haptics::ToString(fault) +
                          " (recovers by itself)";
  } else {
    screen->device_status = ui::DeviceStatus::kSafe;
    screen->device_text =
        label + ", SAFE STATE: " + haptics::ToString(fault) + " - no force; r re-arms";
  }
}

// Everything the screen shows besides the views, from the latest
// publication of the loop and the device's snapshot.
void FillScreenModel(const PanelNumbers& numbers, const haptics::HapticSnapshot& snapshot,
                     const model::ModelState& state, const ves::v1::ColonCase& colon_case,
                     const std::string& device_label, ui::ScreenModel* screen) {
  switch (numbers.state) {
    case training::SessionState::kReady: screen->phase = ui::SessionPhase::kReady; break;
    case training::SessionState::kRunning: screen->phase = ui::SessionPhase::kRunning; break;
    case training::SessionState::kFinished: screen->phase = ui::SessionPhase::kOver; break;
  }
  screen->outcome = OutcomeText(numbers.outcome);
  screen->score = numbers.score;
  screen->elapsed_s = numbers.elapsed_s;
  screen->time_limit_s = numbers.time_limit_s;
  screen->inserted_m = state.inserted_m;
  screen->tip_arc_m = state.tip_arc_m;
  screen->tip_region = patient_db::RegionName(patient_db::CalcRegionAt(colon_case, state.tip_arc_m));
  screen->roll_rad = state.roll_rad;
  screen->hand_force_N = snapshot.force_N;
  screen->score_figures = numbers.score_figures;
  screen->excessive_wall_force_N = numbers.excessive_wall_force_N;
  screen->damage_wall_force_N = numbers.damage_wall_force_N;
  screen->damage_penalty_points = numbers.damage_penalty_points;
  DescribeDevice(snapshot, device_label, screen);
}

// What the two views show besides the model's state.
struct ViewControls {
  training::ViewMode view_mode{};
  bool fluoroscopy_visible{false};
  FluoroscopyControls fluoro;
  bool operator==(const ViewControls&) const = default;
};

ViewControls ViewControlsOf(const ui::ControlState& c) {
  return {
      c.view_mode, c.fluoroscopy_visible,
      FluoroscopyControls{c.fluoro_yaw_rad, c.fluoro_pitch_rad, c.fluoro_zoom, c.damage_display}};
}

// A lesson's aids that are off stay off, whatever the keys and panel ask.
void EnforceAids(const ves::v1::LessonAids* lesson_aids, ui::ControlState* c) {
  if (lesson_aids == nullptr) return;
  if (!lesson_aids->fluoroscopy_allowed()) c->fluoroscopy_visible = false;
  if (!lesson_aids->wireframe_allowed() && c->view_mode == training::ViewMode::kWireframe) {
    c->view_mode = training::ViewMode::kFlat;
  }
}

// The screen's fixed parts and the controls it starts from: the case and
// scope lists with the current choice (a lesson offers none), whether
// fluoroscopy may be shown, the lesson's aids enforced.
void StartScreen(const ves::v1::ColonCase& colon_case, const ves::v1::LessonAids* lesson_aids,
                 const InteractiveChoices* choices, ui::ScreenModel* screen,
                 ui::ControlState* controls) {
  EnforceAids(lesson_aids, controls);
  screen->case_names = {colon_case.id()};
  screen->scope_names = {"default"};
  screen->fluoroscopy_allowed = lesson_aids == nullptr || lesson_aids->fluoroscopy_allowed();
  if (choices != nullptr && !choices->case_names.empty() && !choices->scope_names.empty()) {
    screen->case_names = choices->case_names;
    screen->scope_names = choices->scope_names;
    controls->case_choice = choices->current_case;
    controls->scope_choice = choices->current_scope;
  }
}

// The training screen on the UI thread until the trainee quits or picks
// another case or scope: composes the screen from the loop's latest
// publication, polls keys and mouse, hands the controls to the loop and the
// keyboard's hand target to the simulated hand. Returns the chosen case and
// scope when the run is to switch.
struct ScreenExit {
  std::optional<int> next_case;
  std::optional<int> next_scope;
};

ScreenExit RunTrainingScreen(const training::CaseRun& run, const ves::v1::ColonCase& colon_case,
                             const ves::v1::LessonAids* lesson_aids,
                             const InteractiveChoices* choices, const std::string& device_label,
                             ui::TrainingWindow* window, SessionViews* views, CoupledLoop* loop,
                             haptics::SeqLock<HandTarget>* hand, InteractiveLive* live,
                             JournalKeeper* journal, const training::Sitting* sitting,
                             ui::EvdevGamepad* gamepad,
                             const std::function<void(EndedSession)>& keep) {
  ui::ControlState controls;
  ui::ScreenModel screen;
  StartScreen(colon_case, lesson_aids, choices, &screen, &controls);
  training::Sitting own_sitting;
  render::SceneGeometry scene;
  model::ModelState shown_state;
  model::StepOutput shown_output;
  PanelNumbers numbers;
  std::uint64_t shown_sequence = 0;
  cv::Mat endoscope;
  cv::Mat fluoroscopy;
  std::optional<ViewControls> rendered_with;  // the controls of the views shown; none yet
  auto next_screen = std::chrono::steady_clock::now();
  auto last_activity = next_screen;  // a new state, a view change or an input
  auto last_gamepad_poll = next_screen;
  while (!controls.quit_requested) {
    const bool fresh =
        loop->TakePublication(&shown_sequence, &shown_state, &shown_output, &numbers);
    loop->DrainJournal(journal);  // before the records: an ended session's inputs are all in
    for (auto& session : loop->TakeEndedRecords()) {
      // The debrief of the session that just ended, with the sitting's best
      // and last (the caller's sitting, which keep() adds it to; else this
      // run's own).
      screen.debrief = session.result.debrief;
      if (sitting == nullptr) own_sitting.Add(session.record, session.result);
      keep(std::move(session));
      screen.sitting_line = ui::SittingLine(sitting != nullptr ? *sitting : own_sitting);
    }
    if (fresh) render::FillSceneFromModel(run.params, shown_state, &shown_output, {}, &scene);
    const haptics::HapticSnapshot snapshot = loop->Latest();
    FillScreenModel(numbers, snapshot, shown_state, colon_case, device_label, &screen);
    const ViewControls wanted = ViewControlsOf(controls);
    const bool views_changed = fresh || rendered_with != wanted;
    const auto now = std::chrono::steady_clock::now();
    if (views_changed) last_activity = now;
    if (views_changed && shown_sequence > 0) {
      endoscope = views->Endoscope(scene, wanted.view_mode);
      fluoroscopy =
          wanted.fluoroscopy_visible ? views->Fluoroscopy(scene, wanted.fluoro) : cv::Mat();
      rendered_with = wanted;
    }
    if (fresh) {
      // Built here, not in the loop: the 1 kHz thread only copied plain values.
      live->OnPublication(
          numbers.session_uuid.data(), numbers.state == training::SessionState::kRunning,
          numbers.live.t_s, [&] { return MakeLiveFrame(shown_state, numbers.live); },
          [&] { return EncodeLiveJpeg(endoscope); });
    } else {
      live->Poll();
    }
    if (now >= next_screen) {
      window->Show(ui::ComposeScreen(window->layout(), endoscope, fluoroscopy, screen, controls));
      const auto period = now - last_activity < kIdleAfter ? kScreenPeriod : kIdleScreenPeriod;
      next_screen += period;
      if (next_screen < now) next_screen = now + period;  // fell behind: no burst
    }
    // Nothing is due before the next screen; a key or a click ends the wait
    // at once (waitKeyEx).
    const auto until_screen = std::chrono::duration_cast<std::chrono::milliseconds>(
        next_screen - std::chrono::steady_clock::now());
    const int wait_ms = static_cast<int>(std::clamp<std::int64_t>(until_screen.count(), 1, 100));
    if (window->Poll(wait_ms, screen, &controls) > 0) {
      last_activity = std::chrono::steady_clock::now();
      next_screen = last_activity;  // show the key's effect at once
    }
    if (gamepad != nullptr) {
      // The controller's axes held since the last frame move the hand and knobs.
      const auto polled = std::chrono::steady_clock::now();
      if (gamepad->Poll()) last_activity = polled;
      ui::ApplyGamepad(gamepad->axes(),
                       std::chrono::duration<double>(polled - last_gamepad_poll).count(),
                       ui::GamepadRates{}, ui::KeyboardHand{}, &controls);
      last_gamepad_poll = polled;
    }
    EnforceAids(lesson_aids, &controls);
    if (controls.repeat_requested && choices != nullptr &&
        (controls.case_choice != choices->current_case ||
         controls.scope_choice != choices->current_scope)) {
      // Another case or scope: this run ends, the caller starts that one.
      return {controls.case_choice, controls.scope_choice};
    }
    if (controls.repeat_requested) {
      // The hand stays where it is; the new session maps the model onto it
      // and starts clean (X-ray off, C-arm home) at its first insertion.
      controls.repeat_requested = false;
      ui::StartClean(&controls);
      EnforceAids(lesson_aids, &controls);
      loop->Repeat(snapshot.fault);
    }
    controls.hand_insertion_m = std::clamp(controls.hand_insertion_m, snapshot.insertion_m - kKeyLead_m,
                                           snapshot.insertion_m + kKeyLead_m);
    hand->Store(HandTarget{controls.hand_insertion_m, controls.hand_roll_rad});
    loop->SetControls(ModelControls{controls.knob_up_rad, controls.knob_right_rad,
                                    controls.view_mode, controls.fluoroscopy_visible,
                                    controls.abdominal_press, controls.patient_position});
  }
  return {};
}

}  // namespace

InteractiveResult RunInteractive(const training::CaseRun& run,
                                 const ves::v1::ColonCase& colon_case, double time_limit_s,
                                 InteractiveDevice device, const ves::v1::LessonAids* lesson_aids,
                                 const InteractiveChoices* choices,
                                 const InteractiveLiveTarget* live_target,
                                 const SessionEndedCallback& on_session_ended,
                                 const std::filesystem::path& journal_dir,
                                 const training::Sitting* sitting) {
  ui::TrainingWindow window;  // throws first when there is no display
  std::optional<ui::EvdevGamepad> gamepad;
  if (!device.gamepad.empty()) gamepad.emplace(device.gamepad);
  SessionViews views(run.params, colon_case);
  haptics::SeqLock<HandTarget> hand;
  InteractiveRig rig(std::move(device), run.params.dt_s, &hand);
  InteractiveLive live(live_target ? live_target->server : std::nullopt, run.config.trainee_id,
                       live_target ? live_target->case_id : colon_case.id(),
                       live_target ? live_target->case_version : 0);
  std::optional<JournalKeeper> journal;
  if (!journal_dir.empty()) journal.emplace(journal_dir, run, colon_case, time_limit_s);
  CoupledLoop loop(run, colon_case, time_limit_s, &rig);
  // Records of sessions that end while the screen runs: to the caller at
  // once (its journal locked until then), or kept for the result.
  std::vector<EndedSession> ended;
  const auto keep = [&](EndedSession session) {
    if (on_session_ended) {
      const std::string uuid = session.record.uuid();
      on_session_ended(std::move(session));
      if (journal) journal->Release(uuid);
    } else {
      ended.push_back(std::move(session));
    }
  };
  const ScreenExit exit = RunTrainingScreen(run, colon_case, lesson_aids, choices, rig.label(),
                                            &window, &views, &loop, &hand, &live,
                                            journal ? &*journal : nullptr, sitting,
                                            gamepad ? &*gamepad : nullptr, keep);
  loop.Stop();
  InteractiveResult result = loop.Finish();
  if (on_session_ended) {
    // The last session's too, while the journal keeper still holds its lock.
    for (auto& session : result.records) keep(std::move(session));
    result.records.clear();
  }
  result.records.insert(result.records.begin(), std::make_move_iterator(ended.begin()),
                        std::make_move_iterator(ended.end()));
  std::ostringstream live_report;
  live.Finish(live_report);
  result.live_report = live_report.str();
  result.next_case = exit.next_case;
  result.next_scope = exit.next_scope;
  return result;
}

}  // namespace ves::station