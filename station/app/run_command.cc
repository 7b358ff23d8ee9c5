// ves-station run: one training session on a case, from getting the case to
// the server's acknowledgement (docs/station-run.md).
//   headless: a scripted operator drives the model; frames and a summary go to --out.
//   interactive: the three windows; the keyboard and mouse drive the simulated hand.
// Either way the finished session is committed to the outbox before any upload.
// Exit status (the same for `sim`): 0 a session ran to its end, whatever its
// outcome; 2 bad arguments or input (no such case); 1 the station failed
// (outbox, output folder, ...) or the model diverged.
#include <unistd.h>

#include <algorithm>
#include <boost/program_options.hpp>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <memory>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <string_view>
#include <thread>
#include <utility>
#include <vector>

#include "patient_db/limits.h"
#include "station/app/case_argument.h"
#include "station/app/command_line.h"
#include "station/app/commands.h"
#include "station/app/haptic_session.h"
#include "station/app/live_publish.h"
#include "station/app/run_interactive.h"
#include "station/app/run_lesson.h"
#include "station/app/run_sync.h"
#include "station/app/run_views.h"
#include "station/app/scope_file.h"
#include "station/haptics/candump_log.h"
#include "station/haptics/sim_rig.h"
#include "station/render/model_scene.h"
#include "station/render/render_error.h"
#include "station/sync/session_journal.h"
#include "station/sync/station_paths.h"
#include "station/training/case_run.h"
#include "station/training/replay.h"
#include "station/training/scripted_operator.h"
#include "station/training/session_file.h"
#include "station/training/session_runner.h"
#include "station/training/sitting.h"
#include "station/training/uuid.h"

namespace ves::station {
namespace {

namespace po = boost::program_options;

constexpr char kName[] = "ves-station run";
constexpr int kExitOk = 0;
constexpr int kExitFailed = 1;
constexpr int kExitUsage = 2;
// For the crash tests: with this set, the process SIGKILLs itself right after
// the outbox commit, before any upload (docs/station-run.md).
constexpr char kKillAfterCommitEnv[] = "VES_STATION_KILL_AFTER_COMMIT";
// Frames the --can-log ring holds before dropping (the writer thread drains it;
// headless runs faster than real time).
constexpr std::size_t kCanLogCapacity = std::size_t{1} << 18;

constexpr char kUsage[] =
    "usage: ves-station run --trainee ID --case ID|FILE|--lesson next [--server ADDR --token T\n"
    "                       [--tls-ca FILE]]\n"
    "                       [--device sim|can:IFACE] [--scope FILE] [--data-dir DIR]\n"
    "                       [--headless --operator novice|expert --out DIR] [--seconds LIMIT]\n"
    "                       [--can-log FILE] [--gamepad /dev/input/eventN] [--no-live]\n"
    "                       [--realtime]\n\n"
    "Gets the case (the server's latest version into the offline cache, else the cached one;\n"
    "a case FILE is read and put into the cache),\n"
    "runs one session through the haptic device (the simulated VES-IV over a CAN socketpair,\n"
    "or SocketCAN), commits it to the outbox, then uploads it. Headless: a scripted operator's\n"
    "hand drives the simulated device; endoscope frames, fluoroscopy.png, summary.txt,\n"
    "device.txt and session.session go to DIR.\n"
    "Exit status: 0 the session ran to its end (any outcome), 2 bad arguments/input,\n"
    "1 failure (the model diverged, the outbox or --out could not be written).";

struct UsageError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

struct RunOptions {
  std::optional<sync::ServerEndpoint> server;
  std::string trainee_id;
  std::string case_id;
  std::string lesson;  // "next": run the trainee's next lesson (docs/lessons.md)
  bool seconds_given{false};
  double verdict_wait_s{30.0};
  std::optional<LessonPlan> lesson_plan;  // set by Run when --lesson
  std::string scope_path;
  std::string data_dir;
  std::string station_id;
  bool headless{false};
  std::string operator_kind;
  std::string can_interface;  // empty: the simulated device
  std::string can_log;
  std::string gamepad;  // evdev device of a game controller; empty: none
  std::filesystem::path out_dir;
  double seconds{600.0};
  double frame_period_s{5.0};
  int upload_attempts{3};
  bool live{true};       // with a server: stream the session (docs/station-run.md)
  bool realtime{false};  // headless: simulated time no faster than the wall clock
};

std::string HostName() {
  char name[256] = {};
  if (gethostname(name, sizeof(name) - 1) != 0 || name[0] == '\0') return "station";
  return name;
}

RunOptions ParseRunOptions(const po::variables_map& vm) {
  RunOptions o;
  if (!vm.count("trainee")) throw UsageError("--trainee ID is required");
  if (vm.count("case") == vm.count("lesson")) {
    throw UsageError("give --case ID|FILE or --lesson next (one of them)");
  }
  if (vm.count("lesson")) {
    o.lesson = vm["lesson"].as<std::string>();
    if (o.lesson != "next") throw UsageError("--lesson '" + o.lesson + "' must be next");
    if (vm.count("scope")) {
      throw UsageError("--scope cannot be used with --lesson: the lesson names its scope");
    }
  }
  o.seconds_given = !vm["seconds"].defaulted();
  o.verdict_wait_s = vm["verdict-wait-s"].as<double>();
  o.trainee_id = vm["trainee"].as<std::string>();
  if (vm.count("case")) o.case_id = vm["case"].as<std::string>();
  if (vm.count("server") != vm.count("token")) {
    throw UsageError("--server ADDR and --token T go together");
  }
  if (vm.count("server")) {
    sync::ServerEndpoint endpoint;
    endpoint.address = vm["server"].as<std::string>();
    endpoint.token = vm["token"].as<std::string>();
    if (vm.count("tls-ca")) endpoint.tls_ca_file = vm["tls-ca"].as<std::string>();
    endpoint.deadline = std::chrono::seconds(10);
    try {
      sync::CheckEndpoint(endpoint);
    } catch (const std::invalid_argument& error) {
      throw UsageError(error.what());
    }
    o.server = endpoint;
  } else if (vm.count("tls-ca")) {
    throw UsageError("--tls-ca needs --server");
  }
  const std::string device = vm["device"].as<std::string>();
  if (device.rfind("can:", 0) == 0 && device.size() > 4) {
    o.can_interface = device.substr(4);
  } else if (device != "sim") {
    throw UsageError("--device '" + device + "' must be sim or can:IFACE");
  }
  if (vm.count("can-log")) o.can_log = vm["can-log"].as<std::string>();
  if (vm.count("gamepad")) {
    o.gamepad = vm["gamepad"].as<std::string>();
    if (!o.can_interface.empty() || vm.count("headless")) {
      throw UsageError("--gamepad moves the simulated hand of an interactive run: it needs "
                       "--device sim and no --headless");
    }
  }
  if (vm.count("scope")) o.scope_path = vm["scope"].as<std::string>();
  o.data_dir = vm["data-dir"].as<std::string>();
  o.station_id = vm.count("station-id") ? vm["station-id"].as<std::string>() : HostName();
  // Ids go into the record and to the server: refused here, before a session
  // runs, rather than by the server after it (docs/server.md, "Limits").
  for (const auto& [flag, id] : {std::pair<const char*, const std::string*>{"--trainee",
                                                                            &o.trainee_id},
                                 {"--case", &o.case_id},
                                 {"--station-id", &o.station_id}}) {
    if ((!id->empty() || std::string_view(flag) != "--case") && !patient_db::IsPrintableId(*id)) {
      throw UsageError(std::string(flag) + " '" + patient_db::PrintableExcerpt(*id, 40) +
                       "' must be 1.." + std::to_string(patient_db::kMaxIdBytes) +
                       " bytes of printable UTF-8");
    }
  }
  o.headless = vm.count("headless") > 0;
  if (o.headless) {
    if (!vm.count("operator")) throw UsageError("--headless needs --operator novice|expert");
    if (!vm.count("out")) throw UsageError("--headless needs --out DIR");
    o.operator_kind = vm["operator"].as<std::string>();
    if (o.operator_kind != "novice" && o.operator_kind != "expert") {
      throw UsageError("--operator must be novice or expert, not '" + o.operator_kind + "'");
    }
    o.out_dir = vm["out"].as<std::string>();
    if (!o.can_interface.empty()) {
      throw UsageError("--headless moves the simulated hand: it needs --device sim, not can:" +
                       o.can_interface);
    }
  } else if (vm.count("operator")) {
    throw UsageError("--operator needs --headless (interactively, you are the operator)");
  }
  if (vm.count("out") && !o.headless) o.out_dir = vm["out"].as<std::string>();
  o.seconds = vm["seconds"].as<double>();
  if (!std::isfinite(o.seconds) || o.seconds <= 0.0 || o.seconds > 3600.0) {
    throw UsageError("--seconds " + std::to_string(o.seconds) + " must be in (0, 3600]");
  }
  o.frame_period_s = vm["frame-every-s"].as<double>();
  if (!std::isfinite(o.frame_period_s) || o.frame_period_s <= 0.0) {
    throw UsageError("--frame-every-s " + std::to_string(o.frame_period_s) + " must be > 0");
  }
  o.live = vm.count("no-live") == 0;
  o.realtime = vm.count("realtime") > 0;
  if (o.realtime && !o.headless) throw UsageError("--realtime needs --headless");
  o.upload_attempts = vm["upload-attempts"].as<int>();
  if (o.upload_attempts < 1 || o.upload_attempts > 20) {
    throw UsageError("--upload-attempts " + std::to_string(o.upload_attempts) +
                     " must be in [1, 20]");
  }
  return o;
}


void WritePng(const std::filesystem::path& path, const cv::Mat& image) {
  if (!cv::imwrite(path.string(), image)) {
    throw std::runtime_error("cannot write '" + path.string() + "'");
  }
}

// Writes endoscope frames every frame_period_s of simulated time and, at the
// end, the last endoscope image and the fluoroscopy with damage display. A
// station without EGL still runs the session: it says so and writes none.
class FrameWriter {
 public:
  FrameWriter(const training::CaseRun& run, const ves::v1::ColonCase& colon_case,
              std::filesystem::path dir, double period_s)
      : params_(run.params), dir_(std::move(dir)), period_s_(period_s) {
    try {
      views_.emplace(params_, colon_case);
    } catch (const std::exception& error) {
      std::cerr << kName << ": no frames (the views cannot render here: " << error.what() << ")\n";
    }
  }

  void OnStep(const training::InputSample& input, const training::SessionRunner& runner) {
    if (!views_) return;
    const double t_s = runner.state().time_s;
    if (t_s + 1e-9 < next_frame_s_) return;
    next_frame_s_ += period_s_;
    char name[64];
    std::snprintf(name, sizeof(name), "endoscope_%06.1fs.png", t_s);
    render::FillSceneFromModel(params_, runner.state(), &runner.output(), {}, &scene_);
    WritePng(dir_ / name, views_->Endoscope(scene_, input.view_mode));
    ++frames_;
  }

  // A lesson without fluoroscopy renders none (show_fluoroscopy false).
  void Finish(const training::SessionRunner& runner, training::ViewMode mode,
              bool show_fluoroscopy = true) {
    if (!views_) return;
    render::FillSceneFromModel(params_, runner.state(), &runner.output(), {}, &scene_);
    WritePng(dir_ / "endoscope_final.png", views_->Endoscope(scene_, mode));
    ++frames_;
    if (!show_fluoroscopy) return;
    FluoroscopyControls controls;
    controls.damage_display = true;
    WritePng(dir_ / "fluoroscopy.png", views_->Fluoroscopy(scene_, controls));
    ++frames_;
  }

  int frames() const { return frames_; }

  // The endoscope image now as a small JPEG for live proctoring (320 pixels
  // wide, quality 70); "" when the views cannot render here.
  std::string EndoscopeJpeg(const training::SessionRunner& runner, training::ViewMode mode) {
    if (!views_) return {};
    render::FillSceneFromModel(params_, runner.state(), &runner.output(), {}, &scene_);
    return EncodeLiveJpeg(views_->Endoscope(scene_, mode));
  }

 private:
  const model::ModelParams& params_;
  std::filesystem::path dir_;
  double period_s_;
  double next_frame_s_{0.0};
  std::optional<SessionViews> views_;
  render::SceneGeometry scene_;
  int frames_{0};
};

// With a server, tries to deliver the outbox (every pending record, oldest
// first) and says what became of `uuids`, the sessions this run committed.
// Returns false when the outbox could not be opened.
bool DeliverCommitted(const RunOptions& o, const sync::StationPaths& paths,
                      const std::vector<std::string>& uuids) {
  if (!o.server) {
    std::cout << "no --server: the session waits in the outbox (ves-station sync delivers it)\n";
    return true;
  }
  try {
    sync::Outbox outbox(paths.outbox_db());
    const DeliveryReport report = DeliverOutbox(*o.server, outbox, o.upload_attempts);
    std::cout << "uploaded " << report.acknowledged << " session(s) to " << o.server->address;
    if (report.rejected > 0) std::cout << ", " << report.rejected << " refused by the server";
    std::cout << "; " << report.still_pending << " pending\n";
    for (const auto& pending : outbox.Pending()) {
      for (const auto& uuid : uuids) {
        if (pending.uuid != uuid) continue;
        std::cout << "server unreachable (" << report.last_error << "): session " << uuid
                  << " stays in the outbox; `ves-station status` lists it, `ves-station sync` "
                     "or a later run delivers it\n";
      }
    }
    if (report.rejected > 0) {
      std::cerr << kName << ": the server refused a session: " << report.last_error << "\n";
    }
    return true;
  } catch (const std::exception& error) {
    std::cerr << kName << ": cannot open the outbox to deliver it: " << error.what() << "\n";
    return false;
  }
}

// Commits one record to the outbox; false (said on stderr) when that failed.
bool CommitRecord(const sync::StationPaths& paths, const ves::v1::SessionRecord& record) {
  try {
    sync::Outbox outbox(paths.outbox_db());
    outbox.Commit(record);
    std::cout << "session " << record.uuid() << " committed to the outbox\n" << std::flush;
    return true;
  } catch (const std::exception& error) {
    std::cerr << kName << ": cannot commit session " << record.uuid()
              << " to the outbox: " << error.what() << "\n";
    return false;
  }
}

// The inputs of a journal, chunk by chunk up to the first that does not
// decode (written while the station died); *complete false then.
std::vector<training::InputSample> JournaledInputs(const sync::JournalContents& journal,
                                                   bool* complete) {
  std::vector<training::InputSample> inputs;
  *complete = !journal.torn_tail;
  for (const std::string& chunk : journal.chunks) {
    try {
      const std::vector<training::InputSample> part = training::DecodeInputSamples(chunk);
      inputs.insert(inputs.end(), part.begin(), part.end());
    } catch (const training::InputLogError&) {
      *complete = false;
      break;
    }
  }
  return inputs;
}

// Sessions a previous run left unfinished (it died mid-session): each
// journal is re-run into an aborted session's record and committed to the
// outbox, then deleted. One that cannot be recovered is moved to
// journal/unreadable/ with the reason said, never deleted. When the outbox
// cannot be opened the journals stay for the next run.
void RecoverInterruptedSessions(const sync::StationPaths& paths) {
  sync::RemoveStaleJournalParts(paths.journal());
  const std::vector<std::filesystem::path> journals = sync::ListJournals(paths.journal());
  if (journals.empty()) return;
  std::optional<sync::Outbox> outbox;
  try {
    outbox.emplace(paths.outbox_db());
  } catch (const std::exception& error) {
    std::cerr << kName << ": " << journals.size()
              << " interrupted session(s) wait in the journal: cannot open the outbox: "
              << error.what() << "\n";
    return;
  }
  for (const std::filesystem::path& path : journals) {
    if (sync::JournalInUse(path)) {
      std::cout << "session " << path.stem().string()
                << " is still running in another station process: its journal is left alone\n";
      continue;
    }
    try {
      const sync::JournalContents journal = sync::ReadSessionJournal(path);
      const std::string& uuid = journal.header.uuid();
      std::error_code ignored;
      if (outbox->Find(uuid)) {  // its record was stored before the journal was deleted
        std::filesystem::remove(path, ignored);
        continue;
      }
      bool complete = true;
      const std::vector<training::InputSample> inputs = JournaledInputs(journal, &complete);
      if (inputs.empty()) {  // it had not stepped: nothing to record, as in a live run
        std::filesystem::remove(path, ignored);
        continue;
      }
      const ves::v1::SessionRecord record = training::RecoverSession(journal.header, inputs);
      outbox->Commit(record);
      std::filesystem::remove(path, ignored);
      if (!record.lesson_id().empty()) {
        // A lesson's attempt, like a live one: its verdict is awaited.
        try {
          sync::LessonCache(paths.lessons()).AddAwaited({uuid, record.lesson_id()});
        } catch (const std::exception& error) {
          std::cerr << kName << ": the server's verdict on session " << uuid
                    << " will not be awaited: " << error.what() << "\n";
        }
      }
      std::cout << "session " << uuid << " recovered from the journal of an interrupted run ("
                << std::fixed << std::setprecision(1) << record.metrics().duration_s()
                << " s of inputs" << (complete ? "" : ", its last chunk torn") << ", outcome "
                << training::OutcomeName(static_cast<training::Outcome>(record.outcome()))
                << "): committed to the outbox\n"
                << std::defaultfloat;
    } catch (const std::exception& error) {  // JournalError, ReplayError, InputLogError, disk
      std::error_code moved;
      const std::filesystem::path aside = paths.journal() / "unreadable" / path.filename();
      std::filesystem::create_directories(aside.parent_path(), moved);
      if (!moved) std::filesystem::rename(path, aside, moved);
      std::cerr << kName << ": cannot recover '" << path.string() << "': " << error.what()
                << (moved ? " (left where it is)" : "; set aside as " + aside.string()) << "\n";
    }
  }
}

// Commits the records, then (with a server) tries to deliver the outbox.
// Returns false when a commit itself failed.
bool CommitAndDeliver(const RunOptions& o, const sync::StationPaths& paths,
                      const std::vector<ves::v1::SessionRecord>& records) {
  std::vector<std::string> uuids;
  for (const auto& record : records) {
    if (!CommitRecord(paths, record)) return false;
    uuids.push_back(record.uuid());
  }
  if (std::getenv(kKillAfterCommitEnv) != nullptr) std::raise(SIGKILL);
  return DeliverCommitted(o, paths, uuids);
}

// An interactive sitting's records, each committed to the outbox as soon as
// its session ends (marked as the lesson's attempt first, on a lesson), so
// that a station that crashes or loses power later loses none of them. A
// record whose commit fails is held and tried again at the end.
class SittingRecords {
 public:
  SittingRecords(const RunOptions& o, const sync::StationPaths& paths,
                 sync::LessonCache* lessons)
      : o_(o), paths_(paths), lessons_(lessons) {}

  void Keep(EndedSession ended) {
    ves::v1::SessionRecord& record = ended.record;
    sitting_.Add(record, ended.result);
    // Every repeat is an attempt. The aids were enforced: a wireframe-free
    // lesson cannot have used the wireframe view.
    if (o_.lesson_plan) {
      record.set_lesson_id(o_.lesson_plan->lesson.lesson_id());
      PrintStationVerdict(o_.lesson_plan->lesson, record, /*wireframe_used=*/false, std::cout);
      try {  // called from the training screen's loop: nothing may escape it
        lessons_->AddAwaited({record.uuid(), record.lesson_id()});
      } catch (const std::exception& error) {
        std::cerr << kName << ": the server's verdict on session " << record.uuid()
                  << " will not be awaited: " << error.what() << "\n";
      }
    }
    uuids_.push_back(record.uuid());
    if (!CommitRecord(paths_, record)) {
      std::cerr << kName << ": session " << record.uuid()
                << " is kept in memory and committed again when the run ends\n";
      held_.push_back(std::move(record));
      return;
    }
    DeleteJournal(record.uuid());
  }
  // At the end: the held records committed; false when one still fails.
  bool CommitHeld() {
    for (const auto& record : held_) {
      if (!CommitRecord(paths_, record)) return false;
      DeleteJournal(record.uuid());
    }
    held_.clear();
    return true;
  }
  const std::vector<std::string>& uuids() const { return uuids_; }
  // Every session kept, with its result: the sitting's summary.
  const training::Sitting& sitting() const { return sitting_; }

 private:
  // The record is in the outbox: its journal is no longer needed.
  void DeleteJournal(const std::string& uuid) {
    std::error_code ignored;
    std::filesystem::remove(sync::JournalPath(paths_.journal(), uuid), ignored);
  }

  const RunOptions& o_;
  const sync::StationPaths& paths_;
  sync::LessonCache* lessons_;
  std::vector<std::string> uuids_;
  std::vector<ves::v1::SessionRecord> held_;
  training::Sitting sitting_;
};

// Writes `line` and a newline to `path`; false when that fails.
bool WriteTextFile(const std::filesystem::path& path, const std::string& line) {
  std::ofstream out(path);
  out << line << "\n";
  if (out.flush()) return true;
  std::cerr << kName << ": cannot write '" << path.string() << "'\n";
  return false;
}

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
      rig.Step();
      if (runner.diverged()) break;
      if (!source.stepped()) {
        // A running session always steps unless the device reads NaN: give up.
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
  std::cout << "frames: " << frames.frames() << " PNG files in " << o.out_dir.string() << "\n";
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

// The device of an interactive run: SocketCAN when --device can:IFACE (throws
// when the interface cannot be opened), else the simulated one.
InteractiveDevice OpenInteractiveDevice(const RunOptions& o) {
  InteractiveDevice device;
  device.can_log = o.can_log;
  device.gamepad = o.gamepad;
  if (!o.can_interface.empty()) device.can_bus = haptics::CanBus::OpenSocketCan(o.can_interface);
  return device;
}

struct ScopeChoice {
  std::string name;
  ves::v1::EndoscopeSpec spec;
};

// The scopes the panel offers: --scope FILE first when given, then the adult
// colonoscope in its long (1.68 m) and intermediate (1.33 m) lengths.
std::vector<ScopeChoice> ScopeChoices(const RunOptions& o) {
  std::vector<ScopeChoice> scopes;
  if (!o.scope_path.empty()) {
    scopes.push_back({std::filesystem::path(o.scope_path).filename().string(),
                      ReadScopeFile(o.scope_path)});
  }
  scopes.push_back({"adult 1.68 m", training::DefaultEndoscopeSpec()});
  ves::v1::EndoscopeSpec intermediate = training::DefaultEndoscopeSpec();
  intermediate.set_working_length_m(1.33);
  scopes.push_back({"adult 1.33 m", intermediate});
  return scopes;
}

// The panel's case list: every case in the offline cache, the running one included.
InteractiveChoices CaseAndScopeChoices(const sync::CaseCache& cache, const std::string& case_id,
                                       const std::vector<ScopeChoice>& scopes) {
  InteractiveChoices choices;
  for (const sync::CachedCase& entry : cache.List()) {
    if (std::find(choices.case_names.begin(), choices.case_names.end(), entry.id) ==
        choices.case_names.end()) {
      choices.case_names.push_back(entry.id);
    }
  }
  const auto it = std::find(choices.case_names.begin(), choices.case_names.end(), case_id);
  if (it == choices.case_names.end()) choices.case_names.push_back(case_id);
  choices.current_case = static_cast<int>(
      std::find(choices.case_names.begin(), choices.case_names.end(), case_id) -
      choices.case_names.begin());
  for (const ScopeChoice& scope : scopes) choices.scope_names.push_back(scope.name);
  return choices;
}

int Run(RunOptions o) {
  // The real device first: a missing interface is bad input, said before anything else.
  InteractiveDevice device;
  try {
    device = OpenInteractiveDevice(o);
  } catch (const std::exception& error) {
    std::cerr << kName << ": --device can:" << o.can_interface << ": " << error.what() << "\n";
    return kExitUsage;
  }
  const sync::StationPaths paths = sync::ResolveStationPaths(o.data_dir);
  RecoverInterruptedSessions(paths);
  std::optional<ObtainedCase> obtained;
  bool obtained_from_file = false;
  ves::v1::EndoscopeSpec scope;
  training::CaseRun run;
  try {
    sync::CaseCache cache = OpenCaseCache(paths, std::cout);
    if (!o.lesson.empty()) {  // LessonRefused: no lesson, or its case fails verification
      sync::LessonCache lesson_cache(paths.lessons());
      o.lesson_plan = ObtainNextLesson(o.server, o.trainee_id, lesson_cache, std::cerr);
      // The lesson sets the time limit; --seconds may only shorten it (a practice cut).
      const double limit_s = o.lesson_plan->lesson.time_limit_s();
      o.seconds = o.seconds_given ? std::min(o.seconds, limit_s) : limit_s;
      obtained = ObtainLessonCase(o.server, o.lesson_plan->lesson, cache, std::cerr);
    } else if (IsCaseFileArgument(o.case_id)) {
      obtained = ObtainCaseFile(o.case_id, cache);
      obtained_from_file = true;
    } else {
      obtained = ObtainCase(o.server, o.case_id, cache, std::cerr);
    }
    if (!obtained) {
      std::cerr << kName << ": " << UnknownCaseMessage(o.case_id, cache)
                << (o.server ? " (and the server did not provide it)" : " (no --server given)")
                << "\n";
      return kExitUsage;
    }
    scope = o.lesson_plan          ? o.lesson_plan->lesson.scope()
            : o.scope_path.empty() ? training::DefaultEndoscopeSpec()
                                   : ReadScopeFile(o.scope_path);
    run = training::PrepareCaseRun(obtained->colon_case, scope, {}, o.seconds);
  } catch (const std::exception& error) {  // CaseError (damaged cache), invalid_argument
    std::cerr << kName << ": " << error.what() << "\n";
    return kExitUsage;
  }
  run.config.trainee_id = o.trainee_id;
  run.config.station_id = o.station_id;
  run.config.case_sha256_hex = obtained->entry.sha256_hex;
  if (o.lesson_plan) run.config.lesson_id = o.lesson_plan->lesson.lesson_id();
  std::cout << "case " << obtained->entry.id << " v" << obtained->entry.version << " sha256="
            << obtained->entry.sha256_hex.substr(0, 16) << "… ("
            << (obtained_from_file      ? "from " + o.case_id + ", now in the offline cache"
                : obtained->from_server ? std::string("from the server")
                                        : std::string("offline cache"))
            << ")\n";
  if (o.lesson_plan) PrintLessonBrief(*o.lesson_plan, o.seconds, std::cout);
  if (o.headless) {
    std::cout << "device: sim (the scripted " << o.operator_kind
              << " operator's hand on the simulated VES-IV, over CAN frames to the coupled "
                 "haptic cycle)\n";
    return RunHeadless(o, paths, *obtained, std::move(run));
  }
  // Without a lesson the panel offers the cached cases and the scopes; a
  // switch ends the run and starts the chosen one (the device comes up again).
  std::vector<ScopeChoice> scopes;
  InteractiveChoices choices;
  if (!o.lesson_plan) {
    try {
      scopes = ScopeChoices(o);
      choices = CaseAndScopeChoices(sync::CaseCache(paths.cases()), obtained->entry.id, scopes);
    } catch (const std::exception& error) {
      std::cerr << kName << ": " << error.what() << "\n";
      return kExitUsage;
    }
  }
  std::optional<sync::LessonCache> lessons;
  if (o.lesson_plan) lessons.emplace(paths.lessons());
  SittingRecords sitting(o, paths, lessons ? &*lessons : nullptr);
  InteractiveResult interactive;
  for (;;) {
    try {
      const InteractiveLiveTarget live{o.live ? o.server : std::nullopt, obtained->entry.id,
                                       obtained->entry.version};
      interactive = RunInteractive(
          run, obtained->colon_case, o.seconds, std::move(device),
          o.lesson_plan ? &o.lesson_plan->lesson.aids() : nullptr,
          o.lesson_plan ? nullptr : &choices, &live,
          [&sitting](EndedSession ended) { sitting.Keep(std::move(ended)); },
          paths.journal(), &sitting.sitting());
    } catch (const render::RenderError& error) {  // no EGL/OpenGL ES here
      // One line that says what to do (the error names what is missing).
      std::cerr << kName << ": the views cannot render (" << error.what()
                << "): install the GPU's or Mesa's EGL and OpenGL ES 3 drivers "
                   "(deploy/install-deps.sh), or run --headless\n";
      if (sitting.uuids().empty()) return kExitFailed;
      break;
    } catch (const std::exception& error) {  // no display, the device did not come up
      std::cerr << kName << ": " << error.what() << "\n";
      if (sitting.uuids().empty()) return kExitFailed;
      break;  // what the earlier runs recorded is already committed
    }
    std::cout << interactive.device_report << "\n" << interactive.live_report;
    for (auto& ended : interactive.records) sitting.Keep(std::move(ended));
    if (!interactive.next_case || !interactive.next_scope) break;
    try {
      choices.current_case = *interactive.next_case;
      choices.current_scope = *interactive.next_scope;
      sync::CaseCache cache(paths.cases());
      const std::string& next_id = choices.case_names.at(choices.current_case);
      const std::optional<sync::CachedCase> entry = cache.FindLatest(next_id);
      if (!entry) throw std::runtime_error("case '" + next_id + "' left the offline cache");
      obtained = ObtainedCase{*entry, cache.Load(entry->sha256_hex), false};
      const ScopeChoice& next_scope = scopes.at(choices.current_scope);
      run = training::PrepareCaseRun(obtained->colon_case, next_scope.spec, {}, o.seconds);
      run.config.trainee_id = o.trainee_id;
      run.config.station_id = o.station_id;
      run.config.case_sha256_hex = obtained->entry.sha256_hex;
      device = OpenInteractiveDevice(o);
      std::cout << "switched to case " << entry->id << " v" << entry->version << " sha256="
                << entry->sha256_hex.substr(0, 16) << "…, scope " << next_scope.name << "\n";
    } catch (const std::exception& error) {
      std::cerr << kName << ": cannot switch: " << error.what() << "\n";
      break;
    }
  }
  if (sitting.uuids().empty()) {
    std::cout << sitting.sitting().Report();
    return kExitOk;
  }
  if (!sitting.CommitHeld()) return kExitFailed;
  if (std::getenv(kKillAfterCommitEnv) != nullptr) std::raise(SIGKILL);
  if (!DeliverCommitted(o, paths, sitting.uuids())) return kExitFailed;
  if (lessons && o.server) {
    CollectServerVerdicts(*o.server, *lessons, sitting.uuids().back(), o.verdict_wait_s,
                          std::cout);
  }
  // Every session of the sitting, not only the last (the summary lines as
  // `ves-station replay` prints them), then the best and the last.
  std::cout << sitting.sitting().Report();
  if (interactive.result.diverged) {
    std::cerr << kName << ": the model diverged: the session did not run to its end\n";
    return kExitFailed;
  }
  return kExitOk;
}

}  // namespace

int RunRunCommand(const CommandArgs& args) {
  po::options_description desc("options");
  desc.add_options()("help,h", "show this help")("server", po::value<std::string>(),
                                                 "server address host:port")(
      "token", po::value<std::string>(), "station bearer token")(
      "tls-ca", po::value<std::string>(),
      "CA of the server certificate (PEM); none: plaintext, loopback --server only")(
      "trainee", po::value<std::string>(), "trainee id")(
      "case", po::value<std::string>(),
      "case id (cached or on the server), or a case file (.textproto, .vescase, .csv, "
      ".mrk.json) put into the offline cache first")(
      "lesson", po::value<std::string>(),
      "next: the trainee's next lesson instead of --case (docs/lessons.md)")(
      "verdict-wait-s", po::value<double>()->default_value(30.0),
      "with --lesson: how long to wait for the server's verdict after the upload")(
      "device", po::value<std::string>()->default_value("sim"), "sim or can:IFACE")(
      "scope", po::value<std::string>(), "EndoscopeSpec textproto (default: adult colonoscope)")(
      "data-dir", po::value<std::string>()->default_value(""),
      "station data folder (default $VES_STATION_DIR or ~/.ves-station)")(
      "station-id", po::value<std::string>(), "this station's name (default: the host name)")(
      "headless", "no windows: a scripted operator runs the session")(
      "operator", po::value<std::string>(), "with --headless: novice or expert")(
      "out", po::value<std::string>(), "with --headless: folder for frames and summary.txt")(
      "seconds", po::value<double>()->default_value(600.0), "session time limit, s")(
      "frame-every-s", po::value<double>()->default_value(5.0),
      "headless: an endoscope frame per this much simulated time")(
      "upload-attempts", po::value<int>()->default_value(3),
      "upload passes (with backoff) before leaving the session pending")(
      "can-log", po::value<std::string>(), "every CAN frame of the device, candump log format")(
      "gamepad", po::value<std::string>(),
      "with --device sim: a game controller's evdev device (/dev/input/eventN) as the hand")(
      "no-live", "with --server: do not stream the running session for live proctoring")(
      "realtime", "headless: pace the session to the wall clock (a live demo)");
  po::variables_map vm;
  if (auto stop = ParseCommandLine(kName, kUsage, args, desc, &vm)) return *stop;
  RunOptions options;
  try {
    options = ParseRunOptions(vm);
  } catch (const std::exception& e) {
    std::cerr << kName << ": " << e.what() << "\n";
    return kExitUsage;
  }
  return Run(options);
}

int RunSyncCommand(const CommandArgs& args) {
  po::options_description desc("options");
  desc.add_options()("help,h", "show this help")(
      "server", po::value<std::string>(), "server address host:port")(
      "token", po::value<std::string>(), "station bearer token")(
      "tls-ca", po::value<std::string>(), "CA of the server certificate (PEM)")(
      "data-dir", po::value<std::string>()->default_value(""),
      "station data folder (default $VES_STATION_DIR or ~/.ves-station)")(
      "attempts", po::value<int>()->default_value(3), "passes (with backoff) before giving up")(
      "verdict-wait-s", po::value<double>()->default_value(30.0),
      "how long to wait for the server's verdicts on uploaded lesson sessions")(
      "add", po::value<std::vector<std::string>>()->composing(),
      "queue this session file (e.g. from `sim --session-out`) in the outbox first; "
      "repeatable. Without --server: only queue");
  sync::ServerEndpoint endpoint;
  std::string data_dir;
  int attempts = 3;
  double verdict_wait_s = 30.0;
  po::variables_map vm;
  if (auto stop = ParseCommandLine(
          "ves-station sync",
          "usage: ves-station sync --server ADDR --token T [--tls-ca FILE] [--data-dir DIR]\n"
          "                        [--add FILE.session]...\n"
          "   or: ves-station sync --add FILE.session... [--data-dir DIR]   (queue only)\n\n"
          "Uploads the outbox's pending sessions. --add first queues session files (as\n"
          "`sim --operator ... --session-out` writes them) like a finished run. Exit status 0\n"
          "when none is left pending (or, queue only, when all were queued), 1 when some are\n"
          "(server unreachable), 2 for a bad file.",
          args, desc, &vm)) {
    return *stop;
  }
  std::vector<std::string> to_add;
  if (vm.count("add")) to_add = vm["add"].as<std::vector<std::string>>();
  const bool queue_only = !to_add.empty() && !vm.count("server") && !vm.count("token");
  try {
    if (!queue_only && (!vm.count("server") || !vm.count("token"))) {
      throw UsageError("--server ADDR and --token T are required (or only --add FILE to queue)");
    }
    if (!queue_only) {
      endpoint.address = vm["server"].as<std::string>();
      endpoint.token = vm["token"].as<std::string>();
      if (vm.count("tls-ca")) endpoint.tls_ca_file = vm["tls-ca"].as<std::string>();
    }
    data_dir = vm["data-dir"].as<std::string>();
    attempts = vm["attempts"].as<int>();
    verdict_wait_s = vm["verdict-wait-s"].as<double>();
    if (attempts < 1 || attempts > 20) {
      throw UsageError("--attempts " + std::to_string(attempts) + " must be in [1, 20]");
    }
    // Queuing only talks to no server: there is no endpoint to check.
    if (!queue_only) sync::CheckEndpoint(endpoint);
  } catch (const std::exception& e) {
    std::cerr << "ves-station sync: " << e.what() << "\n";
    return kExitUsage;
  }
  // A session an interrupted run left in the journal goes to the outbox
  // first, so that this sync delivers it too.
  RecoverInterruptedSessions(sync::ResolveStationPaths(data_dir));
  // Session files to queue: each read whole and checked (a truncated or
  // damaged file, a record without trainee) before any is committed.
  std::vector<ves::v1::SessionRecord> added;
  for (const std::string& file : to_add) {
    try {
      std::ifstream in(file, std::ios::binary);
      if (!in) throw std::runtime_error("cannot read it");
      std::ostringstream bytes;
      bytes << in.rdbuf();
      ves::v1::SessionRecord record = training::DecodeSessionFile(bytes.str());
      if (record.trainee_id().empty()) {
        throw std::runtime_error("the session names no trainee (write it with `sim ... --trainee ID`)");
      }
      added.push_back(std::move(record));
    } catch (const std::exception& error) {
      std::cerr << "ves-station sync: --add " << file << ": " << error.what() << "\n";
      return kExitUsage;
    }
  }
  try {
    sync::Outbox outbox(sync::ResolveStationPaths(data_dir).outbox_db());
    for (const auto& record : added) {
      outbox.Commit(record);
      std::cout << "session " << record.uuid() << " (trainee " << record.trainee_id() << ", case "
                << record.case_id() << ") queued in the outbox\n";
    }
    if (queue_only) {
      std::cout << outbox.PendingCount() << " pending; `ves-station sync --server ADDR --token T` "
                   "uploads them\n";
      return kExitOk;
    }
    const DeliveryReport report = DeliverOutbox(endpoint, outbox, attempts);
    std::cout << "uploaded " << report.acknowledged << " session(s), " << report.rejected
              << " refused, " << report.still_pending << " pending\n";
    // Lesson sessions uploaded now or earlier: their server verdicts arrive here.
    sync::LessonCache lessons(sync::ResolveStationPaths(data_dir).lessons());
    if (!lessons.Awaited().empty()) {
      CollectServerVerdicts(endpoint, lessons, "*", verdict_wait_s, std::cout);
    }
    if (report.still_pending > 0) {
      std::cerr << "ves-station sync: still pending: " << report.last_error << "\n";
      return kExitFailed;
    }
    return kExitOk;
  } catch (const std::exception& error) {
    std::cerr << "ves-station sync: " << error.what() << "\n";
    return kExitFailed;
  }
}

}  // namespace ves::station
