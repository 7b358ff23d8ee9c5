// ves-station replay: re-runs the model from a session file's input log and
// recomputes every metric (docs/scoring.md, "Replay").
#include <boost/program_options.hpp>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <sstream>
#include <string>

#include "station/app/command_line.h"
#include "station/app/commands.h"
#include "station/training/case_run.h"
#include "station/training/debrief.h"
#include "station/training/input_log.h"
#include "station/training/session_file.h"

namespace ves::station {
namespace po = boost::program_options;
namespace {

constexpr char kUsage[] =
    "usage: ves-station replay SESSION_FILE [--csv OUT] [--debrief]\n\n"
    "Re-runs the model from the session's input log alone and prints\n"
    "outcome=... time_to_cecum_s=... pain_s=... loop_s=... peak_force_N=... xray_s=...\n"
    "press_llq_s=... press_mid_s=... position_changes=... score=...\n"
    "With --debrief, then the score's weighed parts, one a line, with where and when each\n"
    "cost points (docs/scoring.md, \"Debrief\"), as the station prints them at the quit.\n"
    "A truncated or corrupted file is refused (exit status 2).";

void WriteCsvHeader(std::ostream& out) {
  out << "t_s,inserted_m,tip_arc_m,base_force_N,max_wall_force_N,peak_stretch_m,loop_index_m,"
         "thrust_mode,insertion_cmd_m,push_force_N,roll_rad,knob_up_rad,knob_right_rad,"
         "view_mode,fluoroscopy_on,abdominal_press,patient_position\n";
}

void WriteCsvRow(std::ostream& out, const training::InputSample& in,
                 const training::SessionRunner& runner) {
  const training::StepObservation& o = runner.observation();
  char row[512];
  std::snprintf(row, sizeof(row),
                "%.3f,%.6f,%.6f,%.4f,%.4f,%.6f,%.6f,%d,%.6f,%.4f,%.6f,%.6f,%.6f,%d,%d,%d,%d\n",
                o.t_s, o.inserted_m, o.tip_arc_m, o.base_force_N, o.max_wall_force_N,
                o.peak_stretch_m, runner.session().accumulator().loop_index_m(),
                static_cast<int>(in.thrust_mode), in.insertion_m, in.push_force_N, in.roll_rad,
                in.knob_up_rad, in.knob_right_rad, static_cast<int>(in.view_mode),
                in.fluoroscopy_on ? 1 : 0, static_cast<int>(in.abdominal_press),
                static_cast<int>(in.patient_position));
  out << row;
}

}  // namespace

int RunReplayCommand(const CommandArgs& args) {
  po::options_description options("options");
  options.add_options()("help,h", "show this help")("session", po::value<std::string>(),
                                                    "session file (*.session)")(
      "csv", po::value<std::string>(), "write the replayed run, one row per model step, to OUT")(
      "debrief", "also print the score's weighed parts (docs/scoring.md, \"Debrief\")");
  po::positional_options_description positional;
  positional.add("session", 1);
  po::variables_map vm;
  if (auto stop = ParseCommandLine("ves-station replay", kUsage, args, options, &vm, positional)) {
    return *stop;
  }
  if (!vm.count("session")) {
    std::cerr << "ves-station replay: missing SESSION_FILE (see --help)\n";
    return 2;
  }
  const std::string path = vm["session"].as<std::string>();
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    std::cerr << "ves-station replay: cannot read " << path << "\n";
    return 2;
  }
  std::ostringstream bytes;
  bytes << in.rdbuf();

  std::ofstream csv;
  if (vm.count("csv")) {
    csv.open(vm["csv"].as<std::string>());
    if (!csv) {
      std::cerr << "ves-station replay: cannot write " << vm["csv"].as<std::string>() << "\n";
      return 2;
    }
    WriteCsvHeader(csv);
  }
  try {
    const v1::SessionRecord record = training::DecodeSessionFile(bytes.str());
    training::StepCallback on_step;
    if (csv.is_open()) {
      on_step = [&csv](const training::InputSample& sample, const training::SessionRunner& runner) {
        WriteCsvRow(csv, sample, runner);
      };
    }
    const training::RunResult result = training::ReplayRecord(record, on_step);
    const training::Metrics recorded = training::FromProto(record.metrics());
    if (!(recorded == result.metrics)) {
      std::cerr << "ves-station replay: note: the replayed metrics differ from the recorded ones"
                << " (recorded with build '" << record.software_version() << "')\n";
    }
    std::cout << training::SummaryLine(result) << "\n";
    if (vm.count("debrief")) std::cout << training::DebriefText(result.debrief, "  ");
  } catch (const training::SessionFileError& e) {
    std::cerr << "ves-station replay: " << path << ": " << e.what() << "\n";
    return 2;
  } catch (const training::InputLogError& e) {
    std::cerr << "ves-station replay: " << path << ": " << e.what() << "\n";
    return 2;
  } catch (const training::ReplayError& e) {
    std::cerr << "ves-station replay: " << path << ": " << e.what() << "\n";
    return 2;
  }
  if (csv.is_open() && !csv.flush()) {
    std::cerr << "ves-station replay: writing the CSV failed\n";
    return 1;
  }
  return 0;
}

}  // namespace ves::station
