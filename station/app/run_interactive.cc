#include "station/app/run_interactive.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <mutex>
#include <string>
#include <opencv2/highgui.hpp>
#include <thread>

#include "station/app/run_sync.h"
#include "station/app/run_views.h"
#include "station/training/replay.h"
#include "station/haptics/seqlock.h"
#include "station/render/model_scene.h"
#include "station/training/session_runner.h"
#include "station/training/uuid.h"
#include "station/ui/control_panel.h"
#include "station/ui/station_windows.h"

namespace ves::station {
namespace {

using Clock = std::chrono::steady_clock;

// The simulated hand follows the keyboard's insertion target no faster than a
// person pushes a colonoscope, so a key press is a push, not a jump.
constexpr double kHandSpeed_m_per_s = 0.15;
constexpr auto kPublishPeriod = std::chrono::milliseconds(16);  // ~60 Hz to the UI
constexpr auto kMaxLag = std::chrono::milliseconds(50);  // behind more: drop the backlog
constexpr int kPollMs = 5;
constexpr int kViewHeight = 480;      // SessionViews' default image size
constexpr int kQtWindowWidth = 1500;  // highgui's Qt window with its toolbar
constexpr int kWindowMargin = 80;     // title bar and status line

// UI -> model: what the hand and the panel ask for (trivially copyable, SeqLock).
struct HandCommand {
  double insertion_m{0.0};
  double roll_rad{0.0};
  double knob_up_down_rad{0.0};
  double knob_left_right_rad{0.0};
  training::ViewMode view_mode{training::ViewMode::kTextured};
  bool fluoroscopy_on{false};
  bool quit{false};
  std::uint32_t repeat_count{0};
};

// Model -> UI: the latest scene and live metrics. The model thread only
// try_locks it, so a slow frame on the UI side never stalls a model step.
struct Published {
  render::SceneGeometry scene;
  ui::PanelModel panel;
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


std::string StateText(const training::Session& session) {
  if (session.state() == training::SessionState::kRunning) return "running";
  if (session.state() == training::SessionState::kReady) return "ready";
  return std::string("finished: ") + training::OutcomeName(session.outcome()) +
         " (r: repeat, q: quit)";
}

// The model thread: 1 kHz steps paced by the steady clock, the hand command
// read lock-free, finished sessions collected as records.
class ModelThread {
 public:
  ModelThread(const training::CaseRun& run, const ves::v1::ColonCase& colon_case,
              double time_limit_s, const haptics::SeqLock<HandCommand>* hand,
              std::mutex* published_mutex, Published* published)
      : runner_(run.params, run.config),
        colon_case_(colon_case),
        time_limit_s_(time_limit_s),
        hand_(hand),
        published_mutex_(published_mutex),
        published_(published) {}

  void Run() {
    runner_.Start(start_ms_ = NowUnixMs());
    const auto period = std::chrono::duration_cast<Clock::duration>(
        std::chrono::duration<double>(runner_.params().dt_s));
    auto next = Clock::now();
    auto next_publish = next;
    std::uint32_t repeats_seen = 0;
    double commanded_m = 0.0;
    while (true) {
      HandCommand command;
      hand_->Load(&command);
      if (command.quit) break;
      if (command.repeat_count != repeats_seen) {
        repeats_seen = command.repeat_count;
        FinishAndKeep();
        runner_.Repeat();
        commanded_m = 0.0;
        runner_.Start(start_ms_ = NowUnixMs());
      }
      if (runner_.session().state() == training::SessionState::kRunning) {
        const double max_move_m = kHandSpeed_m_per_s * runner_.params().dt_s;
        commanded_m += std::clamp(command.insertion_m - commanded_m, -max_move_m, max_move_m);
        training::InputSample input;
        input.thrust_mode = training::ThrustMode::kPosition;
        input.insertion_m = std::max(0.0, commanded_m);
        input.roll_rad = command.roll_rad;
        input.knob_up_down_rad = command.knob_up_down_rad;
        input.knob_left_right_rad = command.knob_left_right_rad;
        input.view_mode = command.view_mode;
        input.fluoroscopy_on = command.fluoroscopy_on;
        runner_.Step(input);
      }
      const auto now = Clock::now();
      if (now >= next_publish) {
        if (Publish()) next_publish = now + kPublishPeriod;
      }
      next += period;
      if (now - next > kMaxLag) next = now;  // fell behind (a stall): do not race to catch up
      std::this_thread::sleep_until(next);
    }
    FinishAndKeep();
  }

  InteractiveResult TakeResult() { return std::move(result_); }

 private:
  // Non-blocking: skipped (and retried next step) while the UI copies.
  bool Publish() {
    std::unique_lock<std::mutex> lock(*published_mutex_, std::try_to_lock);
    if (!lock.owns_lock()) return false;
    render::FillSceneFromModel(runner_.params(), runner_.state(), &runner_.output(), {},
                               &published_->scene);
    const training::Session& session = runner_.session();
    const training::Metrics metrics = session.metrics();
    ui::PanelModel& panel = published_->panel;
    panel.case_names = {colon_case_.id()};
    panel.scope_names = {"default"};
    panel.session_state = StateText(session);
    panel.elapsed_s = metrics.duration_s;
    panel.inserted_m = runner_.state().inserted_m;
    panel.tip_arc_m = runner_.state().tip_arc_m;
    panel.base_force_N = runner_.observation().base_force_N;
    panel.excessive_force_N = session.config().thresholds.excessive_wall_force_N;
    panel.pain_s = metrics.pain_s;
    panel.loop_s = metrics.loop_s;
    panel.xray_s = metrics.xray_s;
    panel.redout_fraction = runner_.observation().redout_fraction;
    ++published_->sequence;
    return true;
  }

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

  training::SessionRunner runner_;
  const ves::v1::ColonCase& colon_case_;
  double time_limit_s_;
  const haptics::SeqLock<HandCommand>* hand_;
  std::mutex* published_mutex_;
  Published* published_;
  std::int64_t start_ms_{0};
  InteractiveResult result_;
};

}  // namespace

InteractiveResult RunInteractive(const training::CaseRun& run,
                                 const ves::v1::ColonCase& colon_case, double time_limit_s) {
  ui::StationWindows windows;  // throws first when there is no display
  // Tiled rather than stacked at the screen's corner: the two views one above
  // the other, the panel to their right (Qt's toolbar makes windows wide).
  cv::moveWindow(ui::StationWindows::kEndoscopeWindow, 0, 0);
  cv::moveWindow(ui::StationWindows::kFluoroscopyWindow, 0, kViewHeight + kWindowMargin);
  cv::moveWindow(ui::StationWindows::kPanelWindow, kQtWindowWidth + kWindowMargin, 0);
  SessionViews views(run.params, colon_case);
  haptics::SeqLock<HandCommand> hand;
  std::mutex published_mutex;
  Published published;
  ModelThread model(run, colon_case, time_limit_s, &hand, &published_mutex, &published);
  std::thread model_thread([&model] { model.Run(); });

  ui::ControlState controls;
  HandCommand command;
  render::SceneGeometry scene;
  ui::PanelModel panel;
  std::uint64_t shown_sequence = 0;
  try {
    while (!controls.quit_requested) {
      {
        std::lock_guard<std::mutex> lock(published_mutex);
        if (published.sequence != shown_sequence) {
          scene = published.scene;
          panel = published.panel;
          shown_sequence = published.sequence;
        }
      }
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
      if (controls.repeat_requested) {
        controls.repeat_requested = false;
        controls.hand_insertion_m = 0.0;
        ++command.repeat_count;
      }
      command.insertion_m = controls.hand_insertion_m;
      command.roll_rad = controls.hand_roll_rad;
      command.knob_up_down_rad = controls.knob_up_down_rad;
      command.knob_left_right_rad = controls.knob_left_right_rad;
      command.view_mode = ToTrainingMode(controls.view_mode);
      command.fluoroscopy_on = controls.fluoroscopy_visible;
      command.quit = controls.quit_requested;
      hand.Store(command);
    }
  } catch (...) {
    command.quit = true;
    hand.Store(command);
    model_thread.join();
    throw;
  }
  model_thread.join();
  return model.TakeResult();
}

}  // namespace ves::station
