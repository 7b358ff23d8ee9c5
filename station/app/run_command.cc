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
#include <iostream>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <utility>

#include "patient_db/limits.h"
#include "station/app/case_argument.h"
#include "station/app/command_line.h"
#include "station/app/commands.h"
#include "station/app/journal_recovery.h"
#include "station/app/run_headless.h"
#include "station/app/run_lesson.h"
#include "station/app/run_options.h"
#include "station/app/run_sitting.h"
#include "station/app/run_sync.h"
#include "station/app/scope_file.h"
#include "station/sync/lesson_cache.h"
#include "station/sync/station_paths.h"
#include "station/training/case_model.h"
#include "station/training/case_run.h"

namespace ves::station {
namespace {

namespace po = boost::program_options;

constexpr const char* kName = kRunName;

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
  return RunSitting(o, paths, std::move(*obtained), std::move(run), std::move(device));
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

}  // namespace ves::station
