#include "station/app/run_headless.h"

#include <chrono>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <optional>
#include <string>
#include <thread>

#include "station/app/frame_writer.h"
#include "station/app/haptic_session.h"
#include "station/app/live_publish.h"
#include "station/app/run_lesson.h"
#include "station/app/session_commit.h"
#include "station/haptics/candump_log.h"
#include "station/haptics/sim_rig.h"
#include "station/sync/lesson_cache.h"
#include "station/training/replay.h"
#include "station/training/scripted_operator.h"
#include "station/training/session_file.h"
#include "station/training/session_runner.h"
#include "station/training/uuid.h"

namespace ves::station {
namespace {

constexpr const char* kName = kRunName;
// Frames the --can-log ring holds before dropping (the writer thread drains it;
// headless runs faster than real time).
constexpr std::size_t kCanLogCapacity = std::size_t{1} << 18;

// Writes `line` and a newline to `path`; false when that fails.
bool WriteTextFile(const std::filesystem::path& path, const std::string& line) {
  std::ofstream out(path);
  out << line << "\n";
  if (out.flush()) return true;
  std::cerr << kName << ": cannot write '" << path.string() << "'\n";
  return false;
}

// The session that ran: its record (with the station's health and the
// replay setup), summary.txt and session.session into --out, the lesson's
// verdict, then the outbox and the upload.
int StoreHeadlessSession(const RunOptions& o, const sync::StationPaths& paths,
                         const ObtainedCase& obtained, const training::CaseRun& run,
                         const training::SessionRunner& runner, haptics::SimulatedRig& rig,
                         const std::string& uuid, std::int64_t start_ms, int frames) {
  const training::RunResult result = training::ResultOf(runner);
  const auto duration_ms = static_cast<int64_t>(std::llround(result.metrics.duration_s * 1e3));
  ves::v1::SessionRecord record = runner.session().ToRecord(uuid, start_ms + duration_ms);
  training::CaseModelOptions case_options;
  *record.mutable_replay_setup() =
      training::MakeReplaySetup(obtained.colon_case, case_options, o.seconds);
  if (o.lesson_plan) record.set_lesson_id(o.lesson_plan->lesson.lesson_id());
  // Simulated time: the counters are real, the loop's timing is not measured.
  *record.mutable_station_health() = MakeStationHealth(
      "sim", rig.driver().counters(), rig.cycle().safety(), nullptr, run.params.dt_s);
  const std::string summary = training::SummaryLine(result);
  if (!WriteTextFile(o.out_dir / "summary.txt", summary)) return kExitFailed;
  {
    // The record as `ves-station replay` reads it: the model alone re-runs it.
    std::ofstream out(o.out_dir / "session.session", std::ios::binary);
    out << training::EncodeSessionFile(record);
    if (!out.flush()) {
      std::cerr << kName << ": cannot write '" << (o.out_dir / "session.session").string()
                << "'\n";
      return kExitFailed;
    }
  }
  std::cout << "frames: " << frames << " PNG files in " << o.out_dir.string() << "\n";
  std::optional<sync::LessonCache> lessons;
  if (o.lesson_plan) {
    bool wireframe_used = false;
    for (const auto& in : runner.session().inputs()) {
      wireframe_used = wireframe_used || in.view_mode == training::ViewMode::kWireframe;
    }
    PrintStationVerdict(o.lesson_plan->lesson, record, wireframe_used, std::cout);
    lessons.emplace(paths.lessons());
    lessons->AddAwaited({record.uuid(), record.lesson_id()});
  }
  if (!CommitAndDeliver(o, paths, {record})) return kExitFailed;
  if (lessons && o.server) {
    CollectServerVerdicts(*o.server, *lessons, record.uuid(), o.verdict_wait_s, std::cout);
  }
  std::cout << summary << "\n";
  if (result.diverged) {
    std::cerr << kName << ": the model diverged: the session did not run to its end\n";
    return kExitFailed;
  }
  return kExitOk;
}

}  // namespace

// A scripted operator's hand on the simulated VES-IV: its push force (or
// position) and roll move the simulated hand, the device reports encoders and
// the force sensor over the socketpair CAN bus to Ves4Device, and the coupled
// HapticCycle steps the model from the encoders and renders its response. On
// simulated time (SimulatedRig: no sleeping, deterministic), but the same
// HapticCycle code the 1 kHz loop runs.
int RunHeadless(const RunOptions& o, const sync::StationPaths& paths, const ObtainedCase& obtained,
                training::CaseRun run) {
  try {
    std::filesystem::create_directories(o.out_dir);
  } catch (const std::exception& error) {
    std::cerr << kName << ": cannot create --out '" << o.out_dir.string() << "': " << error.what()
              << "\n";
    return kExitFailed;
  }
  const int64_t start_ms = NowUnixMs();
  auto scripted = training::MakeScriptedOperator(o.operator_kind, run.params.dt_s);
  run.config.operator_kind = o.operator_kind;
  training::SessionRunner runner(run.params, run.config);
  FrameWriter frames(run, obtained.colon_case, o.out_dir, o.frame_period_s);

  haptics::SeqLock<ModelControls> controls;
  SessionModelSource source(&runner, &controls);
  haptics::SimulatedRigOptions rig_options;
  rig_options.cycle.period_s = run.params.dt_s;
  rig_options.cycle.control.mode = haptics::ControlMode::kCoupled;
  haptics::SimulatedRig rig(rig_options, &source);
  std::unique_ptr<haptics::CanFrameRecorder> recorder;
  try {
    if (!o.can_log.empty()) {
      recorder = std::make_unique<haptics::CanFrameRecorder>(
          o.can_log, "sim0", static_cast<double>(start_ms) * 1e-3, kCanLogCapacity);
      rig.driver().SetRecorder(recorder.get());
    }
  } catch (const std::exception& error) {
    std::cerr << kName << ": --can-log: " << error.what() << "\n";
    return kExitFailed;
  }
  if (!rig.BringUp()) {
    std::cerr << kName << ": the simulated device did not become operational\n";
    return kExitFailed;
  }
  const haptics::DeviceState& device = rig.cycle().device_state();
  source.Start(start_ms, device.insertion_m, device.roll_rad);
  const std::string uuid = training::NewUuidV4();
  LivePublisher live(o.live ? o.server : std::nullopt, uuid, o.trainee_id, obtained.entry.id,
                     obtained.entry.version);
  const auto wall_start = std::chrono::steady_clock::now();
  training::Perception perception = training::Perceive(run.params, runner.state(), runner.output());
  training::ViewMode last_view = training::ViewMode::kTextured;
  try {
    while (runner.session().state() == training::SessionState::kRunning) {
      const training::InputSample act =
          o.lesson_plan ? ApplyLessonAids(o.lesson_plan->lesson.aids(), scripted->Act(perception))
                        : scripted->Act(perception);
      rig.device().set_hand(HandForSample(act, source.insertion_offset_m()));
      controls.Store(ModelControls{act.knob_up_rad, act.knob_right_rad, act.view_mode,
                                   act.fluoroscopy_on, act.abdominal_press,
                                   act.patient_position});
      const std::uint64_t steps_before = source.model_steps();
      rig.Step();
      if (runner.diverged()) break;
      if (source.model_steps() == steps_before) {
        // A running session always steps unless the device reads NaN (the
        // cycle then trips the safe state and hands the model nothing): give up.
        std::cerr << kName << ": the device reported non-finite readings: session aborted\n";
        runner.session().Abort();
        break;
      }
      const training::InputSample& logged = runner.session().inputs().back();
      last_view = logged.view_mode;
      frames.OnStep(logged, runner);
      live.OnStep(runner, [&] { return frames.EndoscopeJpeg(runner, logged.view_mode); });
      if (o.realtime) {
        std::this_thread::sleep_until(
            wall_start + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                             std::chrono::duration<double>(runner.state().time_s)));
      }
      perception = training::Perceive(run.params, runner.state(), runner.output());
    }
    live.Finish(std::cout);
    frames.Finish(runner, last_view,
                  !o.lesson_plan || o.lesson_plan->lesson.aids().fluoroscopy_allowed());
  } catch (const std::exception& error) {  // a frame that cannot be written
    std::cerr << kName << ": " << error.what() << "\n";
    return kExitFailed;
  }
  if (recorder) recorder->Close();
  const std::string device_line =
      DeviceReportLine("sim", "socketpair", rig.driver().counters(), source,
                       rig.cycle().safety());
  std::cout << device_line;
  if (recorder) {
    std::cout << " can_log=" << o.can_log << " can_log_frames=" << recorder->written()
              << " can_log_dropped=" << recorder->dropped();
  }
  std::cout << "\n";
  if (!WriteTextFile(o.out_dir / "device.txt", device_line)) return kExitFailed;
  return StoreHeadlessSession(o, paths, obtained, run, runner, rig, uuid, start_ms,
                              frames.frames());
}

}  // namespace ves::station
