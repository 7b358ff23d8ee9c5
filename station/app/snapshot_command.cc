// ves-station snapshot: inserts the scope into a case with the model
// (position-driven), or replays a recorded session to its last step, and
// writes the views of paper §4 as PNG files: the endoscope image in its
// three modes and AP / lateral fluoroscopy.
#include <algorithm>
#include <boost/program_options.hpp>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>
#include <optional>
#include <opencv2/imgcodecs.hpp>
#include <stdexcept>
#include <string>

#include "patient_db/case_format.h"
#include "station/app/case_argument.h"
#include "station/app/command_line.h"
#include "station/app/commands.h"
#include "station/app/run_views.h"
#include "station/model/model.h"
#include "station/render/endoscope_view.h"
#include "station/render/fluoroscopy_labels.h"
#include "station/render/fluoroscopy_view.h"
#include "station/render/model_scene.h"
#include "station/render/mucosa_texture.h"
#include "station/sync/station_paths.h"
#include "station/training/case_model.h"
#include "station/training/case_run.h"
#include "station/training/input_log.h"
#include "station/training/session_file.h"

namespace ves::station {
namespace {

namespace po = boost::program_options;

constexpr char kName[] = "ves-station snapshot";
constexpr double kDegToRad = 3.14159265358979323846 / 180.0;
constexpr double kSettle_s = 0.5;  // knobs turned and the model settled after inserting

constexpr char kUsage[] =
    "usage: ves-station snapshot --case FILE|ID --insert-mm L [--knob-ud DEG --knob-lr DEG]\n"
    "                            [--c-arm-deg A [--tilt-deg T]] [--zoom Z]\n"
    "                            [--width W --height H] [--segments N] [--data-dir DIR]\n"
    "                            --out DIR\n"
    "   or: ves-station snapshot --session FILE.session [--advance-mm D] [--c-arm-deg A\n"
    "                            [--tilt-deg T]] [--zoom Z] [--width W --height H] --out DIR\n\n"
    "--case: a case file (.textproto, .vescase, .csv, .mrk.json) or the id of a case in the\n"
    "station's offline cache (the shipped cases are there from the first start), as for run.\n"
    "Inserts the scope L mm with the model (position-driven), turns the knobs, and writes\n"
    "endoscope_wireframe.png, endoscope_polygon.png, endoscope_texture.png,\n"
    "fluoroscopy_ap.png and fluoroscopy_lateral.png into DIR; with --c-arm-deg also\n"
    "fluoroscopy_c-arm.png from that C-arm angle (0 AP, 90 lateral). --zoom enlarges every\n"
    "fluoroscopy image around the scope's tip. Each carries its view (AP/LAT/OBL), the\n"
    "patient's side at its edges (R/L, A/P) and a scale bar.\n"
    "--session: instead of inserting, replays a recorded session (from `run`, `sim --session-out`)\n"
    "to its last step and shows the scope where it ended, e.g. at the cecum's pole; its case\n"
    "and colon segments are the record's, drawn with the default mucosa texture. --advance-mm\n"
    "then pushes the scope D mm further by position (a session ends where the cecum counts as\n"
    "reached, a few cm before its pole).";

struct UsageError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

struct SnapshotOptions {
  std::string case_path;
  std::string session_path;  // a recorded session instead of case + insertion
  double advance_m{0.0};     // with session_path: pushed in this much further after its end
  std::string data_dir;  // the offline cache, for --case ID
  double insert_m{0.0};
  double insert_speed_m_per_s{0.1};
  double knob_up_rad{0.0};
  double knob_right_rad{0.0};
  int width{640};
  int height{480};
  int segments{150};
  std::optional<double> c_arm_rad;
  double tilt_rad{0.0};
  double zoom{1.0};
  std::filesystem::path out_dir;
};

double Checked(const po::variables_map& vm, const char* name, double low, double high) {
  const double value = vm[name].as<double>();
  if (!std::isfinite(value) || value < low || value > high) {
    throw UsageError(std::string("--") + name + " " + std::to_string(value) + " must be in [" +
                     std::to_string(low) + ", " + std::to_string(high) + "]");
  }
  return value;
}

SnapshotOptions ParseOptions(const po::variables_map& vm) {
  SnapshotOptions o;
  if (!vm.count("out")) throw UsageError("--out DIR is required");
  if (vm.count("session")) {
    // The record fixes the case, the segments and every input.
    for (const char* fixed : {"case", "insert-mm", "knob-ud", "knob-lr", "segments", "data-dir"}) {
      if (vm.count(fixed) && !vm[fixed].defaulted()) {
        throw UsageError(std::string("--") + fixed +
                         " cannot be used with --session: the recorded session sets it");
      }
    }
    o.session_path = vm["session"].as<std::string>();
    o.advance_m = Checked(vm, "advance-mm", 0.0, 300.0) * 1e-3;
  } else {
    if (!vm.count("case")) throw UsageError("--case FILE|ID (or --session FILE) is required");
    if (!vm.count("insert-mm")) throw UsageError("--insert-mm L is required");
    if (!vm["advance-mm"].defaulted()) throw UsageError("--advance-mm needs --session");
    o.case_path = vm["case"].as<std::string>();
    o.insert_m = Checked(vm, "insert-mm", 0.0, 2000.0) * 1e-3;
  }
  o.data_dir = vm["data-dir"].as<std::string>();
  o.insert_speed_m_per_s = Checked(vm, "insert-speed-mm-s", 1.0, 1000.0) * 1e-3;
  o.knob_up_rad = Checked(vm, "knob-ud", -180.0, 180.0) * kDegToRad;
  o.knob_right_rad = Checked(vm, "knob-lr", -180.0, 180.0) * kDegToRad;
  o.width = vm["width"].as<int>();
  o.height = vm["height"].as<int>();
  if (o.width < 16 || o.width > 4096 || o.height < 16 || o.height > 4096) {
    throw UsageError("--width/--height " + std::to_string(o.width) + "x" +
                     std::to_string(o.height) + " must each be in [16, 4096]");
  }
  o.segments = vm["segments"].as<int>();
  if (o.segments < 3 || o.segments > 2000) {
    throw UsageError("--segments " + std::to_string(o.segments) + " must be in [3, 2000]");
  }
  if (vm.count("c-arm-deg")) o.c_arm_rad = Checked(vm, "c-arm-deg", -180.0, 180.0) * kDegToRad;
  o.tilt_rad = Checked(vm, "tilt-deg", -90.0, 90.0) * kDegToRad;
  if (!vm["tilt-deg"].defaulted() && !o.c_arm_rad) {
    throw UsageError("--tilt-deg needs --c-arm-deg");
  }
  o.zoom = Checked(vm, "zoom", 0.25, 8.0);
  o.out_dir = vm["out"].as<std::string>();
  return o;
}

// Inserts at constant speed to the target, then holds while the knobs turn
// and the model settles. Returns false if the model diverged.
bool Insert(const SnapshotOptions& o, const model::ModelParams& params, model::ModelState* state,
            model::StepOutput* output) {
  model::Scratch scratch = model::MakeScratch(params);
  const double insert_s = o.insert_m / o.insert_speed_m_per_s;
  const auto steps = static_cast<long>(std::ceil((insert_s + kSettle_s) / params.dt_s));
  model::StepInput input;
  input.thrust_mode = model::ThrustMode::kPosition;
  for (long i = 1; i <= steps; ++i) {
    const double t_s = i * params.dt_s;
    input.insertion_m = std::min(o.insert_m, o.insert_speed_m_per_s * t_s);
    const double knob_share = std::clamp((t_s - insert_s) / (0.5 * kSettle_s), 0.0, 1.0);
    input.knob_up_rad = knob_share * o.knob_up_rad;
    input.knob_right_rad = knob_share * o.knob_right_rad;
    model::Step(params, input, state, &scratch, output);
    if (!output->finite) return false;
  }
  return true;
}


// The model as a recorded session left it: its run rebuilt from the record
// and replayed to the log's last step. Throws SessionFileError,
// InputLogError or ReplayError for a file that is no usable record.
struct ReplayedEnd {
  model::ModelParams params;
  model::ModelState state;
  model::StepOutput output;
  model::StepInput last_input;  // the hands, knobs, press and position as they ended
  std::string outcome;
};
ReplayedEnd ReplayToEnd(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error("cannot read '" + path + "'");
  std::ostringstream bytes;
  bytes << in.rdbuf();
  const v1::SessionRecord record = training::DecodeSessionFile(bytes.str());
  const training::CaseRun run = training::PrepareReplay(record);
  const std::size_t samples = training::DecodeInputLog(record.input_log()).size();
  if (samples == 0) throw training::ReplayError("the session has no step");
  ReplayedEnd end{run.params, {}, {}, {}, {}};
  // Only the last step's state is kept (copying every step's would cost more
  // than the replay).
  std::size_t seen = 0;
  const training::RunResult result = training::Replay(
      run.params, run.config, record.input_log(),
      [&](const training::InputSample& sample, const training::SessionRunner& runner) {
        if (++seen == samples) {
          end.last_input = training::ToStepInput(sample);
          end.state = runner.state();
          end.output = runner.output();
        }
      });
  end.outcome = training::SummaryLine(result);
  end.outcome = end.outcome.substr(0, end.outcome.find(' '));
  return end;
}

// From a replayed end: the scope pushed `advance_m` further by position at
// the snapshot's insertion speed, everything else as the session left it,
// then settled. Returns false if the model diverged.
bool Advance(const SnapshotOptions& o, ReplayedEnd* end) {
  if (o.advance_m <= 0.0) return true;
  const model::ModelParams& params = end->params;
  model::Scratch scratch = model::MakeScratch(params);
  model::StepInput input = end->last_input;
  input.thrust_mode = model::ThrustMode::kPosition;
  const double from_m = end->state.inserted_m;
  const double push_s = o.advance_m / o.insert_speed_m_per_s;
  const auto steps = static_cast<long>(std::ceil((push_s + kSettle_s) / params.dt_s));
  for (long i = 1; i <= steps; ++i) {
    input.insertion_m = from_m + std::min(o.advance_m, o.insert_speed_m_per_s * i * params.dt_s);
    model::Step(params, input, &end->state, &scratch, &end->output);
    if (!end->output.finite) return false;
  }
  return true;
}

void Write(const std::filesystem::path& path, const cv::Mat& image) {
  if (!cv::imwrite(path.string(), image)) {
    throw std::runtime_error("cannot write '" + path.string() + "'");
  }
}

// The case's model with the scope inserted as --insert-mm and the knobs
// say. Returns 0, or the exit status after saying what went wrong.
int InsertIntoCase(const SnapshotOptions& o, model::ModelParams* params, model::ModelState* state,
                   model::StepOutput* output, cv::Mat* case_texture) {
  try {
    const ves::v1::ColonCase colon_case =
        LoadCaseArgument(o.case_path, sync::ResolveStationPaths(o.data_dir), std::cerr);
    training::CaseModelOptions case_options;
    case_options.segments = o.segments;
    *params = training::MakeModelParams(colon_case, training::DefaultEndoscopeSpec(), case_options);
    if (!colon_case.mucosa_texture().image().empty()) {
      *case_texture = render::DecodeMucosaTexture(colon_case.mucosa_texture().image());
    }
    std::filesystem::create_directories(o.out_dir);
  } catch (const std::exception& e) {  // CaseError, UnknownCaseError, invalid_argument, filesystem_error
    std::cerr << kName << ": " << e.what() << "\n";
    return 2;
  }
  *state = model::MakeInitialState(*params);
  *output = model::MakeStepOutput(*params);
  if (!Insert(o, *params, state, output)) {
    std::cerr << kName << ": the model diverged at t = " << state->time_s << " s\n";
    return 1;
  }
  return 0;
}

int RunSnapshot(const SnapshotOptions& o) {
  model::ModelParams params;
  model::ModelState state;
  model::StepOutput output;
  cv::Mat case_texture;
  std::string ended;  // with --session: how it ended, for the output line
  if (o.session_path.empty()) {
    if (const int status = InsertIntoCase(o, &params, &state, &output, &case_texture)) {
      return status;
    }
  } else {
    try {
      ReplayedEnd end = ReplayToEnd(o.session_path);
      if (!Advance(o, &end)) {
        std::cerr << kName << ": the model diverged pushing on at t = " << end.state.time_s
                  << " s\n";
        return 1;
      }
      params = std::move(end.params);
      state = std::move(end.state);
      output = std::move(end.output);
      ended = " " + end.outcome;
      std::filesystem::create_directories(o.out_dir);
    } catch (const std::exception& e) {  // a file that is no usable record, an unwritable DIR
      std::cerr << kName << ": " << o.session_path << ": " << e.what() << "\n";
      return 2;
    }
  }
  try {
    const render::SceneGeometry scene = render::SceneFromModel(params, state, &output);
    render::GlContext context;
    render::EndoscopeViewOptions endoscope_options;
    endoscope_options.width = o.width;
    endoscope_options.height = o.height;
    render::EndoscopeView endoscope(&context, endoscope_options);
    if (!case_texture.empty()) endoscope.SetMucosaTexture(case_texture);
    for (auto mode : {render::EndoscopeMode::kWireframe, render::EndoscopeMode::kPolygon,
                      render::EndoscopeMode::kTexture}) {
      endoscope.set_mode(mode);
      Write(o.out_dir / (std::string("endoscope_") + render::EndoscopeModeName(mode) + ".png"),
            endoscope.Render(scene).image);
    }
    render::FluoroscopyOptions fluoroscopy_options;
    fluoroscopy_options.width = o.width;
    fluoroscopy_options.height = o.height;
    fluoroscopy_options.damage_display = true;
    render::FluoroscopyView fluoroscopy(&context, fluoroscopy_options);
    render::FluoroscopyCamera framing =
        FrameColon(params, static_cast<double>(o.width) / o.height);
    framing.zoom = o.zoom;
    const auto x_ray = [&](const char* file, double yaw_rad, double tilt_rad) {
      render::FluoroscopyCamera camera = framing;
      camera.yaw_rad = yaw_rad;
      camera.pitch_rad = tilt_rad;
      camera = render::CentreZoomOnTip(camera, scene.X_WTip.translation());
      cv::Mat image = fluoroscopy.Render(scene, camera);
      render::DrawFluoroscopyLabels(render::CalcFluoroscopyLabels(camera, image.size()), &image);
      Write(o.out_dir / file, image);
    };
    x_ray("fluoroscopy_ap.png", 0.0, 0.0);
    x_ray("fluoroscopy_lateral.png", 90.0 * kDegToRad, 0.0);
    if (o.c_arm_rad) x_ray("fluoroscopy_c-arm.png", *o.c_arm_rad, o.tilt_rad);
    std::cout << "inserted_m=" << state.inserted_m << " tip_arc_m=" << state.tip_arc_m << ended
              << " renderer=\"" << context.renderer() << "\" out=" << o.out_dir.string() << "\n";
  } catch (const std::exception& e) {  // RenderError (no EGL/GLES), write failures
    std::cerr << kName << ": " << e.what() << "\n";
    return 1;
  }
  return 0;
}

}  // namespace

int RunSnapshotCommand(const CommandArgs& args) {
  po::options_description desc("options");
  desc.add_options()("help,h", "show this help")("case", po::value<std::string>(),
                                                 "colon case file (.textproto, .vescase, .csv, .mrk.json) or cached case id")(
      "session", po::value<std::string>(),
      "a recorded session (.session): the scope where it ended, instead of --case/--insert-mm")(
      "advance-mm", po::value<double>()->default_value(0.0),
      "with --session: then push the scope this much further (by position, at "
      "--insert-speed-mm-s), e.g. from where the cecum counts as reached to its pole")(
      "insert-mm", po::value<double>(), "inserted length past the anus, mm")(
      "insert-speed-mm-s", po::value<double>()->default_value(100.0), "insertion speed, mm/s")(
      "knob-ud", po::value<double>()->default_value(0.0), "up/down knob, degrees (+ up)")(
      "knob-lr", po::value<double>()->default_value(0.0), "left/right knob, degrees (+ right)")(
      "width", po::value<int>()->default_value(640), "image width, px")(
      "height", po::value<int>()->default_value(480), "image height, px")(
      "segments", po::value<int>()->default_value(150), "colon segment points N")(
      "c-arm-deg", po::value<double>(),
      "C-arm angle about the patient's long axis, degrees (0 AP, 90 lateral): adds "
      "fluoroscopy_c-arm.png")(
      "tilt-deg", po::value<double>()->default_value(0.0), "with --c-arm-deg: tilt, degrees")(
      "zoom", po::value<double>()->default_value(1.0),
      "fluoroscopy enlargement, 0.25..8, centred on the scope's tip")(
      "data-dir", po::value<std::string>()->default_value(""),
      "station data folder, for --case ID (default $VES_STATION_DIR or ~/.ves-station)")(
      "out", po::value<std::string>(), "output directory (created)");
  po::variables_map vm;
  if (auto stop = ParseCommandLine(kName, kUsage, args, desc, &vm)) return *stop;
  SnapshotOptions options;
  try {
    options = ParseOptions(vm);
  } catch (const std::exception& e) {
    std::cerr << kName << ": " << e.what() << "\n";
    return 2;
  }
  return RunSnapshot(options);
}

}  // namespace ves::station
