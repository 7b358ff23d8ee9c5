// ves-station sim: runs the endoscope-colon model (docs/model.md) on a case
// from the command line, pushing with a constant force or inserting at a
// constant speed, and writes one CSV row per 10 ms of simulated time.

#include <boost/program_options.hpp>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <optional>
#include <stdexcept>
#include <string>

#include "patient_db/case_format.h"
#include "station/app/case_argument.h"
#include "station/app/command_line.h"
#include "station/app/commands.h"
#include "station/app/run_sync.h"
#include "station/app/scope_file.h"
#include "station/model/model.h"
#include "station/training/case_model.h"
#include "station/training/case_run.h"
#include "station/sync/case_cache.h"
#include "station/sync/station_paths.h"
#include "station/training/session_file.h"

namespace ves::station {
namespace {

namespace po = boost::program_options;

constexpr char kName[] = "ves-station sim";
constexpr double kRowPeriod_s = 0.010;

constexpr char kUsage[] =
    "usage: ves-station sim --case FILE|ID [--scope FILE] (--push-force-N F | --insert-speed-mm-s V)\n"
    "                       --seconds T [--segments N] [--links n] [--stiff-colon] [--dt-ms DT]\n"
    "                       --csv OUT [--data-dir DIR]\n"
    "   or: ves-station sim --case FILE|ID --operator novice|expert --seconds T\n"
    "                       [--session-out FILE.session [--trainee ID] [--station-id S]]\n"
    "                       [--csv OUT] [--segments N] [--data-dir DIR] ...\n\n"
    "--case: a case file (.textproto, .vescase, .csv, .mrk.json) or the id of a case in the\n"
    "station's offline cache (the shipped cases are there from the first start). A --session-out file can be queued for upload with\n"
    "`ves-station sync --add FILE.session` (it needs --trainee).\n"
    "Runs the endoscope-colon model (paper §3) on a case and writes one row per 10 ms:\n"
    "t_s,inserted_m,tip_arc_m,base_force_N,base_torque_Nm,peak_stretch_m,peak_stretch_arc_m,"
    "peak_wall_force_N. With --operator: one summary line (docs/scoring.md).\n"
    "Exit status (as run): 0 the session ran to its end (any outcome), 2 bad arguments/input,\n"
    "1 failure (the model diverged, an output could not be written).";

// Everything the run needs, parsed and checked; more driving modes (a
// scripted operator) slot in as further fields and a branch in InputAt.
struct SimOptions {
  std::string case_path;
  std::string scope_path;
  std::optional<double> push_force_N;
  std::optional<double> insert_speed_m_per_s;
  double seconds{0.0};
  int segments{150};
  std::optional<int> links;
  bool stiff_colon{false};
  double dt_s{0.001};
  std::string csv_path;
  std::string operator_kind;  // scripted operator (docs/scoring.md); empty: push/speed
  std::string session_out;
  std::string trainee_id;     // written into the session file (for `sync --add`)
  std::string station_id;
  std::string data_dir;       // the offline cache, for --case ID
};

// --case FILE, or the newest cached version of --case ID (the shipped cases
// among them). Throws CaseError or UnknownCaseError.
ves::v1::ColonCase LoadSimCase(const SimOptions& o) {
  // Notes on stderr: stdout is the summary line.
  return LoadCaseArgument(o.case_path, sync::ResolveStationPaths(o.data_dir), std::cerr);
}

struct UsageError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

SimOptions ParseSimOptions(const po::variables_map& vm) {
  SimOptions o;
  if (!vm.count("case")) throw UsageError("--case FILE|ID is required");
  if (!vm.count("seconds")) throw UsageError("--seconds T is required");
  if (!vm.count("csv") && !vm.count("operator")) throw UsageError("--csv OUT is required");
  o.case_path = vm["case"].as<std::string>();
  if (vm.count("scope")) o.scope_path = vm["scope"].as<std::string>();
  if (vm.count("operator")) {
    o.operator_kind = vm["operator"].as<std::string>();
    if (o.operator_kind != "novice" && o.operator_kind != "expert") {
      throw UsageError("--operator must be novice or expert, not '" + o.operator_kind + "'");
    }
    if (vm.count("push-force-N") || vm.count("insert-speed-mm-s")) {
      throw UsageError(
          "--operator drives the scope itself: drop --push-force-N/--insert-speed-mm-s");
    }
    if (vm.count("session-out")) o.session_out = vm["session-out"].as<std::string>();
    if (vm.count("trainee")) o.trainee_id = vm["trainee"].as<std::string>();
    if (vm.count("station-id")) o.station_id = vm["station-id"].as<std::string>();
    if ((vm.count("trainee") || vm.count("station-id")) && o.session_out.empty()) {
      throw UsageError("--trainee and --station-id go into the session file: give --session-out");
    }
  } else if (vm.count("session-out") || vm.count("trainee") || vm.count("station-id")) {
    throw UsageError("--session-out, --trainee and --station-id need --operator");
  } else if (vm.count("push-force-N") == vm.count("insert-speed-mm-s")) {
    throw UsageError("give exactly one of --push-force-N F and --insert-speed-mm-s V");
  }
  if (!o.operator_kind.empty()) {
    // driven by the scripted operator
  } else if (vm.count("push-force-N")) {
    const double f = vm["push-force-N"].as<double>();
    if (!std::isfinite(f) || std::abs(f) > 100.0) {
      throw UsageError("--push-force-N " + std::to_string(f) + " must be within +-100 N");
    }
    o.push_force_N = f;
  } else {
    const double v = vm["insert-speed-mm-s"].as<double>();
    if (!std::isfinite(v) || std::abs(v) > 1000.0) {
      throw UsageError("--insert-speed-mm-s " + std::to_string(v) + " must be within +-1000");
    }
    o.insert_speed_m_per_s = v * 1e-3;
  }
  o.seconds = vm["seconds"].as<double>();
  if (!std::isfinite(o.seconds) || o.seconds <= 0.0 || o.seconds > 3600.0) {
    throw UsageError("--seconds " + std::to_string(o.seconds) + " must be in (0, 3600]");
  }
  o.segments = vm["segments"].as<int>();
  if (o.segments < 3 || o.segments > 2000) {
    throw UsageError("--segments " + std::to_string(o.segments) + " must be in [3, 2000]");
  }
  if (vm.count("links")) {
    const int n = vm["links"].as<int>();
    if (n < 3 || n > 512) throw UsageError("--links " + std::to_string(n) + " must be in [3, 512]");
    o.links = n;
  }
  o.stiff_colon = vm.count("stiff-colon") > 0;
  const double dt_ms = vm["dt-ms"].as<double>();
  if (!std::isfinite(dt_ms) || dt_ms < 0.01 || dt_ms > 10.0) {
    throw UsageError("--dt-ms " + std::to_string(dt_ms) + " must be in [0.01, 10]");
  }
  o.dt_s = dt_ms * 1e-3;
  if (vm.count("csv")) o.csv_path = vm["csv"].as<std::string>();
  o.data_dir = vm["data-dir"].as<std::string>();
  return o;
}

model::ModelParams BuildParams(const SimOptions& o) {
  const ves::v1::ColonCase colon_case = LoadSimCase(o);
  ves::v1::EndoscopeSpec scope =
      o.scope_path.empty() ? training::DefaultEndoscopeSpec() : ReadScopeFile(o.scope_path);
  if (o.links) scope.set_link_count(static_cast<uint32_t>(*o.links));
  training::CaseModelOptions options;
  options.segments = o.segments;
  options.stiff_colon = o.stiff_colon;
  model::ModelParams params = training::MakeModelParams(colon_case, scope, options);
  params.dt_s = o.dt_s;
  model::ValidateParams(params);
  return params;
}

model::StepInput InputAt(const SimOptions& o, double t_s) {
  model::StepInput in;
  if (o.push_force_N) {
    in.thrust_mode = model::ThrustMode::kForce;
    in.push_force_N = *o.push_force_N;
  } else {
    in.thrust_mode = model::ThrustMode::kPosition;
    in.insertion_m = std::max(0.0, *o.insert_speed_m_per_s * t_s);
  }
  return in;
}

void WriteRow(std::ostream& out, const model::ModelState& s, const model::StepOutput& o) {
  char row[256];
  std::snprintf(row, sizeof(row), "%.3f,%.6f,%.6f,%.5f,%.6f,%.6f,%.5f,%.5f\n", s.time_s,
                o.inserted_m, o.tip_arc_m, o.base_force_N, o.roll_torque_Nm, o.peak_stretch_m,
                o.peak_stretch_arc_m, o.peak_wall_force_N);
  out << row;
}

// Runs the model; returns the exit status.
int RunSim(const SimOptions& o, const model::ModelParams& params, std::ostream& csv) {
  model::ModelState state = model::MakeInitialState(params);
  model::Scratch scratch = model::MakeScratch(params);
  model::StepOutput out = model::MakeStepOutput(params);
  csv << "t_s,inserted_m,tip_arc_m,base_force_N,base_torque_Nm,peak_stretch_m,"
         "peak_stretch_arc_m,peak_wall_force_N\n";
  const auto steps = static_cast<long>(std::llround(o.seconds / params.dt_s));
  long rows_written = 0;
  for (long i = 0; i < steps; ++i) {
    model::Step(params, InputAt(o, state.time_s + params.dt_s), &state, &scratch, &out);
    if (!out.finite) {
      std::cerr << kName << ": the model diverged at t = " << state.time_s << " s\n";
      return 1;
    }
    const long rows_due = static_cast<long>(std::floor(state.time_s / kRowPeriod_s + 1e-6));
    if (rows_due > rows_written) {
      WriteRow(csv, state, out);
      rows_written = rows_due;
    }
  }
  return csv.good() ? 0 : 1;
}

// A scripted operator through the training session (docs/scoring.md): writes
// the session file and prints one summary line.
int RunOperatorSim(const SimOptions& o) {
  ves::v1::ColonCase colon_case;
  ves::v1::EndoscopeSpec scope;
  training::CaseModelOptions options;
  try {
    colon_case = LoadSimCase(o);
    scope = o.scope_path.empty() ? training::DefaultEndoscopeSpec() : ReadScopeFile(o.scope_path);
    if (o.links) scope.set_link_count(static_cast<uint32_t>(*o.links));
    options.segments = o.segments;
    options.stiff_colon = o.stiff_colon;
    training::PrepareCaseRun(colon_case, scope, options, o.seconds, o.dt_s);  // validates
  } catch (const std::exception& e) {  // CaseError, invalid_argument
    std::cerr << kName << ": " << e.what() << "\n";
    return 2;
  }
  std::ofstream csv;
  if (!o.csv_path.empty()) {
    csv.open(o.csv_path);
    if (!csv) {
      std::cerr << kName << ": cannot write '" << o.csv_path << "'\n";
      return 2;
    }
    csv << "t_s,inserted_m,tip_arc_m,base_force_N,base_torque_Nm,peak_stretch_m,"
           "peak_stretch_arc_m,peak_wall_force_N\n";
  }
  training::StepCallback on_step;
  if (csv.is_open()) {
    const long every = std::max(1L, std::lround(kRowPeriod_s / o.dt_s));
    on_step = [&csv, every](const training::InputSample& in, const training::SessionRunner& run) {
      if (static_cast<long>(in.tick + 1) % every == 0) WriteRow(csv, run.state(), run.output());
    };
  }
  const auto now_ms = std::chrono::duration_cast<std::chrono::milliseconds>(
                          std::chrono::system_clock::now().time_since_epoch())
                          .count();
  ves::v1::SessionRecord record;
  const training::RunResult result = training::RunScriptedCase(
      colon_case, scope, options, o.operator_kind, o.seconds, now_ms, &record, on_step, o.dt_s);
  if (!o.session_out.empty()) {
    record.set_trainee_id(o.trainee_id);
    record.set_station_id(o.station_id);
    record.set_case_sha256_hex(patient_db::CasePayloadSha256Hex(colon_case));
    std::ofstream out(o.session_out, std::ios::binary);
    out << training::EncodeSessionFile(record);
    if (!out.flush()) {
      std::cerr << kName << ": cannot write '" << o.session_out << "'\n";
      return 1;
    }
  }
  std::cout << training::SummaryLine(result) << "\n";
  // As `run`: a session that ran to its end is a success, whatever its outcome.
  if (result.diverged) {
    std::cerr << kName << ": the model diverged: the session did not run to its end\n";
    return 1;
  }
  return csv.is_open() && !csv.good() ? 1 : 0;
}

}  // namespace

int RunSimCommand(const CommandArgs& args) {
  po::options_description desc("options");
  desc.add_options()("help,h", "show this help")(
      "case", po::value<std::string>(),
      "colon case file (.textproto, .vescase, .csv, .mrk.json) or cached case id")(
      "scope", po::value<std::string>(), "EndoscopeSpec textproto (default: adult colonoscope)")(
      "push-force-N", po::value<double>(), "constant push force at the base, N")(
      "insert-speed-mm-s", po::value<double>(), "constant insertion speed, mm/s")(
      "seconds", po::value<double>(), "simulated time, s")(
      "segments", po::value<int>()->default_value(150), "colon segment points N")(
      "links", po::value<int>(), "endoscope links n (overrides the scope's)")(
      "stiff-colon", "make every suspension stiff (the older, radial-only model)")(
      "dt-ms", po::value<double>()->default_value(1.0), "time step, ms")(
      "csv", po::value<std::string>(), "output CSV path")(
      "operator", po::value<std::string>(), "scripted operator: novice or expert")(
      "session-out", po::value<std::string>(), "with --operator: write the session file here")(
      "trainee", po::value<std::string>(), "with --session-out: the trainee the session is for")(
      "station-id", po::value<std::string>(), "with --session-out: this station's name")(
      "data-dir", po::value<std::string>()->default_value(""),
      "station data folder, for --case ID (default $VES_STATION_DIR or ~/.ves-station)");
  po::variables_map vm;
  if (auto stop = ParseCommandLine(kName, kUsage, args, desc, &vm)) return *stop;
  SimOptions options;
  try {
    options = ParseSimOptions(vm);
  } catch (const std::exception& e) {
    std::cerr << kName << ": " << e.what() << "\n";
    return 2;
  }
  if (!options.operator_kind.empty()) return RunOperatorSim(options);
  model::ModelParams params;
  try {
    params = BuildParams(options);
  } catch (const std::exception& e) {  // CaseError, invalid_argument
    std::cerr << kName << ": " << e.what() << "\n";
    return 2;
  }
  std::ofstream csv(options.csv_path);
  if (!csv) {
    std::cerr << kName << ": cannot write '" << options.csv_path << "'\n";
    return 2;
  }
  return RunSim(options, params, csv);
}

}  // namespace ves::station
