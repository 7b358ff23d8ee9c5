#include "station/app/run_interactive.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <memory>
#include <mutex>
#include <opencv2/highgui.hpp>
#include <optional>
#include <stdexcept>
#include <string>
#include <thread>

#include "station/app/haptic_session.h"
#include "station/app/run_sync.h"
#include "station/app/run_views.h"
#include "station/haptics/candump_log.h"
#include "station/haptics/haptic_loop.h"
#include "station/haptics/realtime.h"
#include "station/haptics/seqlock.h"
#include "station/haptics/sim_rig.h"
#include "station/haptics/simulated_ball_drive.h"
#include "station/haptics/ves4_device.h"
#include "station/training/replay.h"
#include "station/render/model_scene.h"
#include "station/training/session_runner.h"
#include "station/training/uuid.h"
#include "station/ui/control_panel.h"
#include "station/ui/station_windows.h"

namespace ves::station {
namespace {

// The simulated hand follows the keyboard's insertion target no faster than a
// person pushes a colonoscope, so a key press is a push, not a jump.
constexpr double kHandSpeed_m_per_s = 0.15;
constexpr int kPollMs = 5;
constexpr int kViewHeight = 480;      // SessionViews' default image size
constexpr int kQtWindowWidth = 1500;  // highgui's Qt window with its toolbar
constexpr int kWindowMargin = 80;     // title bar and status line

// UI -> simulated hand: where the keyboard wants the scope (device coordinates).
struct HandTarget {
  double insertion_m{0.0};
  double roll_rad{0.0};
};

// Loop -> UI: the model's state every kPublishSteps steps, copied under a
// mutex the loop thread only try_locks (same sizes each time: no allocation),
// so a slow UI frame never stalls the haptic loop (it skips a publication).
struct PanelNumbers {
  training::SessionState state{training::SessionState::kReady};
  training::Outcome outcome{training::Outcome::kNone};
  double elapsed_s{0.0};
  double excessive_force_N{5.0};
  double pain_s{0.0};
  double loop_s{0.0};
  double xray_s{0.0};
  double redout_fraction{0.0};
};
struct Published {
  model::ModelState state;
  model::StepOutput output;
  PanelNumbers numbers;
  std::uint64_t sequence{0};
};

training::ViewMode ToTrainingMode(ui::ViewMode mode) {
  switch (mode) {
    case ui::ViewMode::kWireframe: return training::ViewMode::kWireframe;
    case ui::ViewMode::kPolygon: return training::ViewMode::kFlat;
    case ui::ViewMode::kTexture: break;
  }
  return training::ViewMode::kTextured;
}

render::EndoscopeMode ToRenderMode(ui::ViewMode mode) {
  switch (mode) {
    case ui::ViewMode::kWireframe: return render::EndoscopeMode::kWireframe;
    case ui::ViewMode::kPolygon: return render::EndoscopeMode::kPolygon;
    case ui::ViewMode::kTexture: break;
  }
  return render::EndoscopeMode::kTexture;
}


std::string StateText(const PanelNumbers& numbers, haptics::SafetyFault fault) {
  std::string text;
  if (numbers.state == training::SessionState::kRunning) {
    text = "running";
  } else if (numbers.state == training::SessionState::kReady) {
    text = "ready";
  } else {
    text = std::string("finished: ") + training::OutcomeName(numbers.outcome) +
           " (r: repeat, q: quit)";
  }
  if (fault != haptics::SafetyFault::kNone) {
    text += std::string(" | device safe: ") + haptics::ToString(fault) + " (r re-arms)";
  }
  return text;
}

// The simulated hand gripping the scope on the simulated VES-IV, moved on the
// loop's thread just before the device answers each SYNC: it pulls the scope
// toward the keyboard's target (lock-free from the UI), following it no
// faster than a person pushes a colonoscope (a key press is a push, not a
// jump). Its speed is in device time (one period per SYNC), as the plant's.
class KeyboardHand {
 public:
  KeyboardHand(const haptics::SeqLock<HandTarget>* target, double period_s)
      : target_(target), period_s_(period_s) {}
  void Move(haptics::SimulatedBallDrive* device) {
    HandTarget target;
    target_->Load(&target);
    const double max_move_m = kHandSpeed_m_per_s * period_s_;
    commanded_m_ += std::clamp(target.insertion_m - commanded_m_, -max_move_m, max_move_m);
    device->set_hand(HandAtTargets(commanded_m_, target.roll_rad));
  }

 private:
  const haptics::SeqLock<HandTarget>* target_;
  double period_s_;
  double commanded_m_{0.0};
};

// The session side of the loop thread: repeats asked for by the UI, records
// of finished sessions, publication of the model state to the UI.
class LoopSession {
 public:
  LoopSession(const training::CaseRun& run, const ves::v1::ColonCase& colon_case,
              double time_limit_s, const haptics::SeqLock<ModelControls>* controls,
              std::mutex* published_mutex, Published* published)
      : runner_(run.params, run.config),
        source_(&runner_, controls),
        colon_case_(colon_case),
        time_limit_s_(time_limit_s),
        published_mutex_(published_mutex),
        published_(published) {
    source_.set_before_update([this](double insertion_m, double roll_rad) {
      const std::uint32_t requested = repeat_requests_.load(std::memory_order_acquire);
      if (requested == repeats_done_) return;
      repeats_done_ = requested;
      FinishAndKeep();
      runner_.Repeat();
      source_.Start(start_ms_ = NowUnixMs(), insertion_m, roll_rad);
    });
    source_.set_after_step([this](const training::SessionRunner&) {
      if (++steps_since_publish_ >= kPublishSteps && Publish()) steps_since_publish_ = 0;
    });
  }

  void Start(double device_insertion_m, double device_roll_rad) {
    source_.Start(start_ms_ = NowUnixMs(), device_insertion_m, device_roll_rad);
    Publish();
  }
  // UI thread: the loop finishes the current session and starts another.
  void RequestRepeat() { repeat_requests_.fetch_add(1, std::memory_order_acq_rel); }
  // After the loop stopped (its thread joined).
  InteractiveResult Finish() {
    FinishAndKeep();
    return std::move(result_);
  }
  SessionModelSource* source() { return &source_; }

 private:
  bool Publish() {
    std::unique_lock<std::mutex> lock(*published_mutex_, std::try_to_lock);
    if (!lock.owns_lock()) return false;
    const training::Session& session = runner_.session();
    const training::Metrics metrics = session.metrics();
    published_->state = runner_.state();
    published_->output = runner_.output();
    PanelNumbers& numbers = published_->numbers;
    numbers.state = session.state();
    numbers.outcome = session.outcome();
    numbers.elapsed_s = metrics.duration_s;
    numbers.excessive_force_N = session.config().thresholds.excessive_wall_force_N;
    numbers.pain_s = metrics.pain_s;
    numbers.loop_s = metrics.loop_s;
    numbers.xray_s = metrics.xray_s;
    numbers.redout_fraction = runner_.observation().redout_fraction;
    ++published_->sequence;
    return true;
  }

  // A one-off on repeat (loop thread) and at the end (UI thread, loop stopped).
  void FinishAndKeep() {
    training::Session& session = runner_.session();
    if (session.steps() == 0) return;
    if (session.state() == training::SessionState::kRunning) session.Abort();
    result_.result = training::ResultOf(runner_);
    const auto duration_ms =
        static_cast<std::int64_t>(std::llround(result_.result.metrics.duration_s * 1e3));
    ves::v1::SessionRecord record =
        session.ToRecord(training::NewUuidV4(), start_ms_ + duration_ms);
    *record.mutable_replay_setup() = training::MakeReplaySetup(colon_case_, {}, time_limit_s_);
    result_.records.push_back(std::move(record));
  }

  static constexpr int kPublishSteps = 16;  // ~60 Hz to the UI at 1 kHz
  training::SessionRunner runner_;
  SessionModelSource source_;
  const ves::v1::ColonCase& colon_case_;
  double time_limit_s_;
  std::mutex* published_mutex_;
  Published* published_;
  std::atomic<std::uint32_t> repeat_requests_{0};
  std::uint32_t repeats_done_{0};
  int steps_since_publish_{0};
  std::int64_t start_ms_{0};
  InteractiveResult result_;
};

}  // namespace

InteractiveResult RunInteractive(const training::CaseRun& run,
                                 const ves::v1::ColonCase& colon_case, double time_limit_s,
                                 InteractiveDevice device, const ves::v1::LessonAids* lesson_aids,
                                 const InteractiveChoices* choices) {
  ui::StationWindows windows;  // throws first when there is no display
  if (lesson_aids != nullptr) windows.SetFluoroscopyAllowed(lesson_aids->fluoroscopy_allowed());
  // Tiled rather than stacked at the screen's corner: the two views one above
  // the other, the panel to their right (Qt's toolbar makes windows wide).
  cv::moveWindow(ui::StationWindows::kEndoscopeWindow, 0, 0);
  cv::moveWindow(ui::StationWindows::kFluoroscopyWindow, 0, kViewHeight + kWindowMargin);
  cv::moveWindow(ui::StationWindows::kPanelWindow, kQtWindowWidth + kWindowMargin, 0);
  SessionViews views(run.params, colon_case);

  // The bus: SocketCAN to the real device, or a socketpair to the simulated one.
  const bool simulated = !device.can_bus.has_value();
  std::optional<haptics::CanBus> device_end;
  haptics::CanBus host_end = [&] {
    if (!simulated) return std::move(*device.can_bus);
    auto [host, sim] = haptics::CanBus::CreateSocketPair();
    device_end.emplace(std::move(sim));
    return std::move(host);
  }();
  const std::string bus_name = simulated ? "socketpair" : host_end.name();
  haptics::SimulatedBallDriveOptions device_options;
  device_options.period_s = run.params.dt_s;
  haptics::Ves4DeviceOptions driver_options;
  driver_options.period_s = run.params.dt_s;
  haptics::Ves4Device driver(std::move(host_end), device_options.params, driver_options);
  std::unique_ptr<haptics::CanFrameRecorder> recorder;
  if (!device.can_log.empty()) {
    recorder = std::make_unique<haptics::CanFrameRecorder>(
        device.can_log, simulated ? "sim0" : bus_name, haptics::MonotonicToEpochOffsetSeconds());
    driver.SetRecorder(recorder.get());
  }
  haptics::SeqLock<HandTarget> hand;
  std::unique_ptr<haptics::SimulatedBallDrive> simulated_device;
  std::unique_ptr<haptics::InlineSimulatedDevice> inline_device;
  KeyboardHand keyboard_hand(&hand, run.params.dt_s);
  haptics::HapticDevice* haptic_device = &driver;
  if (simulated) {
    // Served on the loop's thread: it answers every SYNC in time, as the
    // real device's own hardware does (haptics::InlineSimulatedDevice).
    simulated_device =
        std::make_unique<haptics::SimulatedBallDrive>(std::move(*device_end), device_options);
    inline_device =
        std::make_unique<haptics::InlineSimulatedDevice>(&driver, simulated_device.get());
    inline_device->set_before_service(
        [&keyboard_hand](double, haptics::SimulatedBallDrive* device) {
          keyboard_hand.Move(device);
        });
    haptic_device = inline_device.get();
  }
  haptics::DeviceState device_state;
  if (!haptics::BringUpDevice(haptic_device, &device_state, 2.0)) {
    throw std::runtime_error("the VES-IV on " + bus_name +
                             " did not become operational within 2 s");
  }

  haptics::SeqLock<ModelControls> model_controls;
  std::mutex published_mutex;
  Published published;
  LoopSession session(run, colon_case, time_limit_s, &model_controls, &published_mutex,
                      &published);
  session.Start(device_state.insertion_m, device_state.roll_rad);
  haptics::CycleOptions cycle_options;
  cycle_options.period_s = run.params.dt_s;
  cycle_options.control.mode = haptics::ControlMode::kCoupled;
  haptics::HapticCycle cycle(haptic_device, session.source(), cycle_options);
  cycle.SetInitialDeviceState(device_state);
  haptics::LoopOptions loop_options;
  loop_options.period_s = run.params.dt_s;
  haptics::HapticLoop loop(&cycle, loop_options);
  loop.Start();
  const auto stop_all = [&] {
    loop.Stop();
    if (recorder) recorder->Close();
  };
  if (!loop.ArmAfter(20, 2.0)) {
    stop_all();
    throw std::runtime_error("the haptic loop did not start");
  }

  ui::ControlState controls;
  // A lesson's aids that are off stay off, whatever the keys and panel ask.
  auto enforce_aids = [lesson_aids](ui::ControlState* c) {
    if (lesson_aids == nullptr) return;
    if (!lesson_aids->fluoroscopy_allowed()) c->fluoroscopy_visible = false;
    if (!lesson_aids->wireframe_allowed() && c->view_mode == ui::ViewMode::kWireframe) {
      c->view_mode = ui::ViewMode::kPolygon;
    }
  };
  enforce_aids(&controls);
  render::SceneGeometry scene;
  model::ModelState shown_state;
  model::StepOutput shown_output;
  ui::PanelModel panel;
  panel.case_names = {colon_case.id()};
  panel.scope_names = {"default"};
  if (choices != nullptr && !choices->case_names.empty() && !choices->scope_names.empty()) {
    panel.case_names = choices->case_names;
    panel.scope_names = choices->scope_names;
    controls.case_choice = choices->current_case;
    controls.scope_choice = choices->current_scope;
  }
  std::optional<int> next_case;
  std::optional<int> next_scope;
  PanelNumbers numbers;
  std::uint64_t shown_sequence = 0;
  try {
    while (!controls.quit_requested) {
      bool fresh = false;
      {
        // Only copies under the lock (the loop skips a publication meanwhile).
        std::lock_guard<std::mutex> lock(published_mutex);
        if (published.sequence != shown_sequence) {
          shown_state = published.state;
          shown_output = published.output;
          numbers = published.numbers;
          shown_sequence = published.sequence;
          fresh = true;
        }
      }
      if (fresh) {
        render::FillSceneFromModel(run.params, shown_state, &shown_output, {}, &scene);
        panel.inserted_m = shown_state.inserted_m;
        panel.tip_arc_m = shown_state.tip_arc_m;
      }
      haptics::HapticSnapshot snapshot;
      loop.latest().Load(&snapshot);
      panel.session_state = StateText(numbers, snapshot.fault);
      panel.elapsed_s = numbers.elapsed_s;
      // The gauge: what the motors render to the hand, + resists insertion.
      panel.base_force_N = -snapshot.base_thrust_force_N;
      panel.excessive_force_N = numbers.excessive_force_N;
      panel.pain_s = numbers.pain_s;
      panel.loop_s = numbers.loop_s;
      panel.xray_s = numbers.xray_s;
      panel.redout_fraction = numbers.redout_fraction;
      if (shown_sequence > 0) {
        FluoroscopyControls fluoro;
        fluoro.yaw_rad = controls.fluoro_yaw_rad;
        fluoro.pitch_rad = controls.fluoro_pitch_rad;
        fluoro.zoom = controls.fluoro_zoom;
        fluoro.damage_display = controls.damage_display;
        const cv::Mat endoscope = views.Endoscope(scene, ToRenderMode(controls.view_mode));
        const cv::Mat fluoroscopy =
            controls.fluoroscopy_visible ? views.Fluoroscopy(scene, fluoro) : cv::Mat();
        windows.Show(endoscope, fluoroscopy, ui::DrawControlPanel(panel, controls));
      }
      windows.Poll(kPollMs, panel, &controls);
      enforce_aids(&controls);
      if (controls.repeat_requested && choices != nullptr &&
          (controls.case_choice != choices->current_case ||
           controls.scope_choice != choices->current_scope)) {
        // Another case or scope: this run ends, the caller starts that one.
        next_case = controls.case_choice;
        next_scope = controls.scope_choice;
        break;
      }
      if (controls.repeat_requested) {
        // The hand stays where it is; the new session maps the model onto it.
        controls.repeat_requested = false;
        session.RequestRepeat();
        if (snapshot.fault != haptics::SafetyFault::kNone) loop.RequestRearm();
      }
      hand.Store(HandTarget{controls.hand_insertion_m, controls.hand_roll_rad});
      model_controls.Store(ModelControls{controls.knob_up_down_rad, controls.knob_left_right_rad,
                                         ToTrainingMode(controls.view_mode),
                                         controls.fluoroscopy_visible});
    }
  } catch (...) {
    stop_all();
    throw;
  }
  stop_all();
  InteractiveResult result = session.Finish();
  result.next_case = next_case;
  result.next_scope = next_scope;
  result.device_report =
      DeviceReportLine(simulated ? "sim" : "can:" + bus_name, bus_name, driver.counters(),
                       *session.source(), cycle.safety());
  const haptics::LoopStats& stats = loop.stats();
  char timing[160];
  std::snprintf(timing, sizeof(timing),
                " loop_cycles=%llu overruns=%llu p99_period_error_us=%.0f",
                static_cast<unsigned long long>(stats.cycles),
                static_cast<unsigned long long>(stats.overruns),
                static_cast<double>(stats.period_error.PercentileNs(0.99)) / 1000.0);
  result.device_report += timing;
  return result;
}

}  // namespace ves::station
