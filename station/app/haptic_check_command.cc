// ves-station haptic-check: the paper's Fig. 5/6 experiments on the VES-IV
// (or its simulation): run free or spring mode for T seconds while the
// simulated hand moves the scope, write every period to CSV, optionally log
// every CAN frame (candump log format), and end with one summary line per axis.
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include <boost/program_options.hpp>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <memory>
#include <numbers>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "station/app/command_line.h"
#include "station/app/commands.h"
#include "station/haptics/candump_log.h"
#include "station/haptics/haptic_loop.h"
#include "station/haptics/line_fit.h"
#include "station/haptics/realtime.h"
#include "station/haptics/sim_rig.h"

namespace ves::station {
namespace {

namespace po = boost::program_options;
namespace hx = ves::haptics;

constexpr char kName[] = "ves-station haptic-check";
constexpr double kSettle_s = 0.2;  // the hand's start is not part of the figures

struct CheckOptions {
  std::string device;  // "sim" or "can:IFACE"
  hx::ControlMode mode{hx::ControlMode::kFree};
  std::string mode_name;
  double k_N_per_m{100.0};
  double k_Nm_per_rad{0.05};
  double amplitude_m{0.0};
  double frequency_Hz{0.0};
  double seconds{0.0};
  std::string csv_path;
  std::string can_log_path;
  bool simulated_clock{false};
};

int BadArgument(const std::string& message) {
  std::cerr << kName << ": " << message << "\n";
  return 2;
}

// "sine:AMP_MM:FREQ_HZ" -> amplitude and frequency; false if malformed.
bool ParseProfile(const std::string& text, double* amplitude_m, double* frequency_Hz) {
  double amplitude_mm = 0.0;
  double frequency = 0.0;
  char tail = 0;
  if (std::sscanf(text.c_str(), "sine:%lf:%lf%c", &amplitude_mm, &frequency, &tail) != 2) {
    return false;
  }
  if (!(amplitude_mm >= 0.0 && amplitude_mm <= 200.0) || !(frequency > 0.0 && frequency <= 20.0)) {
    return false;
  }
  *amplitude_m = amplitude_mm * 1e-3;
  *frequency_Hz = frequency;
  return true;
}

void WriteCsv(const std::string& path, const std::vector<hx::HapticSnapshot>& rows) {
  std::ofstream out(path);
  out << "t_s,insertion_mm,roll_deg,force_N,torque_Nm,thrust_command_N,roll_command_Nm,fault\n";
  const double t0 = rows.empty() ? 0.0 : rows.front().t_s;
  char line[256];
  for (const auto& row : rows) {
    std::snprintf(line, sizeof(line), "%.6f,%.4f,%.4f,%.5f,%.6f,%.5f,%.6f,%s\n", row.t_s - t0,
                  row.insertion_m * 1e3, row.roll_rad * 180.0 / std::numbers::pi, row.force_N,
                  row.torque_Nm, row.thrust_command_N, row.roll_command_Nm,
                  hx::ToString(row.fault));
    out << line;
  }
}

void PrintSummary(const CheckOptions& options, const std::vector<hx::HapticSnapshot>& rows) {
  std::vector<double> insertion;
  std::vector<double> force;
  std::vector<double> roll;
  std::vector<double> torque;
  const double t0 = rows.empty() ? 0.0 : rows.front().t_s;
  for (const auto& row : rows) {
    if (row.t_s - t0 < kSettle_s) continue;
    insertion.push_back(row.insertion_m);
    force.push_back(row.force_N);
    roll.push_back(row.roll_rad);
    torque.push_back(row.torque_Nm);
  }
  if (insertion.size() < 2) {
    std::cout << "mode=" << options.mode_name << " axis=thrust samples=0\n"
              << "mode=" << options.mode_name << " axis=roll samples=0\n";
    return;
  }
  const hx::AxisSummary thrust = hx::SummarizeAxis(insertion, force);
  const hx::AxisSummary twist = hx::SummarizeAxis(roll, torque);
  char line[256];
  std::snprintf(line, sizeof(line),
                "mode=%s axis=thrust rms_force_N=%.4f max_force_N=%.4f slope_N_per_m=%.2f "
                "r2=%.4f\n",
                options.mode_name.c_str(), thrust.rms_load, thrust.max_abs_load, thrust.fit.slope,
                thrust.fit.r2);
  std::cout << line;
  std::snprintf(line, sizeof(line),
                "mode=%s axis=roll rms_torque_Nm=%.5f max_torque_Nm=%.5f "
                "slope_Nm_per_rad=%.4f r2=%.4f\n",
                options.mode_name.c_str(), twist.rms_load, twist.max_abs_load, twist.fit.slope,
                twist.fit.r2);
  std::cout << line;
}

hx::SimulatedBallDriveOptions DeviceOptions(const CheckOptions& options) {
  hx::SimulatedBallDriveOptions device;
  device.hand.thrust.amplitude = options.amplitude_m;
  device.hand.thrust.frequency_Hz = options.frequency_Hz;
  device.hand.roll = hx::RollLikeThrust(device.hand.thrust, hx::kScopeRadius_m);
  return device;
}

hx::CycleOptions MakeCycleOptions(const CheckOptions& options) {
  hx::CycleOptions cycle;
  cycle.control.mode = options.mode;
  cycle.control.spring_stiffness_N_per_m = options.k_N_per_m;
  cycle.control.spring_stiffness_Nm_per_rad = options.k_Nm_per_rad;
  return cycle;
}

// Simulated time: deterministic, as fast as the CPU allows.
// What the safety monitor saw over the run (docs/can-protocol.md, "Safety").
void PrintSafety(const hx::SafetyMonitor& safety) {
  std::cerr << "safety: transient_faults=" << safety.transient_faults()
            << " recoveries=" << safety.recoveries() << " hard_faults=" << safety.hard_faults()
            << " station_stalls=" << safety.stalls() << " fault=" << hx::ToString(safety.fault())
            << "\n";
}

int RunSimulatedClock(const CheckOptions& options, std::vector<hx::HapticSnapshot>* rows) {
  hx::SimulatedRigOptions rig_options;
  rig_options.device = DeviceOptions(options);
  rig_options.cycle = MakeCycleOptions(options);
  hx::SimulatedRig rig(rig_options);
  std::unique_ptr<hx::CanFrameRecorder> recorder;
  if (!options.can_log_path.empty()) {
    recorder = std::make_unique<hx::CanFrameRecorder>(options.can_log_path, "sim0",
                                                      static_cast<double>(std::time(nullptr)));
    rig.driver().SetRecorder(recorder.get());
  }
  if (!rig.BringUp()) {
    std::cerr << kName << ": simulated device did not come up\n";
    return 1;
  }
  const double start_s = rig.now_s();
  std::uint64_t cycle = 0;
  while (rig.now_s() - start_s < options.seconds) {
    const double t_s = rig.now_s();
    const hx::CycleOutput& output = rig.Step();
    rows->push_back(hx::MakeSnapshot(cycle++, t_s, rig.cycle().device_state(), output));
  }
  if (recorder) recorder->Close();
  PrintSafety(rig.cycle().safety());
  return 0;
}

// The real 1 kHz loop; the simulated device (if any) answers each SYNC on the
// loop's thread, as the real device's own hardware would (InlineSimulatedDevice).
int RunWallClock(const CheckOptions& options, hx::CanBus bus, std::optional<hx::CanBus> sim_bus,
                 std::vector<hx::HapticSnapshot>* rows) {
  const hx::SimulatedBallDriveOptions device_options = DeviceOptions(options);
  hx::Ves4Device driver(std::move(bus), device_options.params);
  std::unique_ptr<hx::CanFrameRecorder> recorder;
  if (!options.can_log_path.empty()) {
    recorder = std::make_unique<hx::CanFrameRecorder>(options.can_log_path, driver.bus().name(),
                                                      hx::MonotonicToEpochOffsetSeconds());
    driver.SetRecorder(recorder.get());
  }
  std::unique_ptr<hx::SimulatedBallDrive> device;
  std::unique_ptr<hx::InlineSimulatedDevice> inline_device;
  hx::HapticDevice* haptic_device = &driver;
  if (sim_bus) {
    device = std::make_unique<hx::SimulatedBallDrive>(std::move(*sim_bus), device_options);
    inline_device = std::make_unique<hx::InlineSimulatedDevice>(&driver, device.get());
    haptic_device = inline_device.get();
  }
  hx::DeviceState state;
  if (!hx::BringUpDevice(haptic_device, &state, 2.0)) {
    std::cerr << kName << ": device on " << driver.bus().name()
              << " did not become operational within 2 s\n";
    return 1;
  }
  hx::HapticCycle cycle(haptic_device, nullptr, MakeCycleOptions(options));
  cycle.SetInitialDeviceState(state);
  hx::SpscRing<hx::HapticSnapshot> trace(1 << 16);
  hx::HapticLoop loop(&cycle, hx::LoopOptions{}, &trace);
  loop.Start();
  if (!loop.ArmAfter(20, 2.0)) {
    loop.Stop();
    std::cerr << kName << ": the haptic loop did not start\n";
    return 1;
  }
  const auto end =
      std::chrono::steady_clock::now() + std::chrono::duration<double>(options.seconds);
  hx::HapticSnapshot snapshot;
  while (std::chrono::steady_clock::now() < end) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
    while (trace.Pop(&snapshot)) rows->push_back(snapshot);
  }
  loop.Stop();
  while (trace.Pop(&snapshot)) rows->push_back(snapshot);
  if (recorder) recorder->Close();
  const hx::LoopStats& stats = loop.stats();
  const hx::DeviceCounters counters = driver.counters();
  char line[256];
  std::snprintf(line, sizeof(line),
                "loop: cycles=%llu overruns=%llu p99_period_error_us=%.0f "
                "max_period_error_us=%.0f lost_frames=%llu bus_errors=%llu malformed_frames=%llu\n",
                static_cast<unsigned long long>(stats.cycles),
                static_cast<unsigned long long>(stats.overruns),
                static_cast<double>(stats.period_error.PercentileNs(0.99)) / 1000.0,
                static_cast<double>(stats.period_error.max_ns()) / 1000.0,
                static_cast<unsigned long long>(counters.lost_frames),
                static_cast<unsigned long long>(counters.bus_errors),
                static_cast<unsigned long long>(counters.malformed_frames));
  std::cerr << line;
  PrintSafety(cycle.safety());
  return 0;
}

}  // namespace

int RunHapticCheckCommand(const CommandArgs& args) {
  CheckOptions options;
  std::string mode;
  std::string profile;
  std::string clock = "wall";
  constexpr char kUsage[] =
      "usage: ves-station haptic-check --device sim|can:IFACE --mode free|spring "
      "[--k-N-per-m K] --profile sine:AMP_MM:FREQ_HZ --seconds T --csv OUT [--can-log FILE]\n\n"
      "Drives the VES-IV (or its simulation) with the simulated hand in free or spring mode\n"
      "(paper Fig. 5/6) and ends with one summary line per axis (thrust, roll).";
  po::options_description description("options");
  description.add_options()("help,h", "show this help")(
      "device", po::value(&options.device)->required(), "sim, or can:IFACE for SocketCAN")(
      "mode", po::value(&mode)->required(), "free or spring")(
      "k-N-per-m", po::value(&options.k_N_per_m)->default_value(100.0),
      "spring mode: thrust spring stiffness, N/m")(
      "k-roll-Nm-per-rad", po::value(&options.k_Nm_per_rad)->default_value(0.05, "0.05"),
      "spring mode: roll torsional stiffness, N·m/rad")(
      "profile", po::value(&profile)->required(),
      "hand motion sine:AMP_MM:FREQ_HZ (thrust; roll moves the scope surface by the same arc)")(
      "seconds", po::value(&options.seconds)->required(), "duration, s")(
      "csv", po::value(&options.csv_path)->required(), "per-period CSV output")(
      "can-log", po::value(&options.can_log_path), "every CAN frame, candump log format")(
      "clock", po::value(&clock)->default_value("wall"),
      "sim device only: wall (the real 1 kHz loop) or sim (simulated time, deterministic)");
  po::variables_map values;
  if (auto stop = ParseCommandLine(kName, kUsage, args, description, &values)) return *stop;
  options.mode_name = mode;
  if (mode == "free") {
    options.mode = hx::ControlMode::kFree;
  } else if (mode == "spring") {
    options.mode = hx::ControlMode::kSpring;
  } else {
    return BadArgument("--mode must be free or spring, got '" + mode + "'");
  }
  if (!(options.k_N_per_m > 0.0 && options.k_N_per_m <= 1e4)) {
    return BadArgument("--k-N-per-m must be in (0, 10000], got " +
                       std::to_string(options.k_N_per_m));
  }
  if (!(options.k_Nm_per_rad > 0.0 && options.k_Nm_per_rad <= 10.0)) {
    return BadArgument("--k-roll-Nm-per-rad must be in (0, 10], got " +
                       std::to_string(options.k_Nm_per_rad));
  }
  if (!ParseProfile(profile, &options.amplitude_m, &options.frequency_Hz)) {
    return BadArgument(
        "--profile must be sine:AMP_MM:FREQ_HZ with 0 <= AMP_MM <= 200 and "
        "0 < FREQ_HZ <= 20, got '" +
        profile + "'");
  }
  if (!(options.seconds > 0.0 && options.seconds <= 3600.0)) {
    return BadArgument("--seconds must be in (0, 3600], got " + std::to_string(options.seconds));
  }
  if (clock != "wall" && clock != "sim") {
    return BadArgument("--clock must be wall or sim, got '" + clock + "'");
  }
  options.simulated_clock = clock == "sim";
  const bool simulated = options.device == "sim";
  if (!simulated && options.device.rfind("can:", 0) != 0) {
    return BadArgument("--device must be sim or can:IFACE, got '" + options.device + "'");
  }
  if (!simulated && options.simulated_clock) {
    return BadArgument("--clock sim needs --device sim");
  }
  spdlog::set_default_logger(spdlog::stderr_color_mt("haptic-check"));

  // A CAN interface that cannot be opened is bad input, as for `run`: said
  // first, exit status 2.
  std::optional<hx::CanBus> can_bus;
  if (!simulated) {
    try {
      can_bus.emplace(hx::CanBus::OpenSocketCan(options.device.substr(4)));
    } catch (const std::exception& error) {
      std::cerr << kName << ": --device " << options.device << ": " << error.what() << "\n";
      return 2;
    }
  }
  std::vector<hx::HapticSnapshot> rows;
  rows.reserve(static_cast<std::size_t>(options.seconds * 1000.0) + 1024);
  int status = 0;
  try {
    if (simulated && options.simulated_clock) {
      status = RunSimulatedClock(options, &rows);
    } else if (simulated) {
      auto [host, device] = hx::CanBus::CreateSocketPair();
      status = RunWallClock(options, std::move(host), std::move(device), &rows);
    } else {
      status = RunWallClock(options, std::move(*can_bus), std::nullopt, &rows);
    }
  } catch (const std::exception& error) {
    std::cerr << kName << ": " << error.what() << "\n";
    return 1;
  }
  if (status != 0) return status;
  // The periods before the first arm (bring-up) are not part of the run.
  std::size_t first_armed = 0;
  while (first_armed < rows.size() && rows[first_armed].fault == hx::SafetyFault::kNotArmed) {
    ++first_armed;
  }
  rows.erase(rows.begin(), rows.begin() + static_cast<std::ptrdiff_t>(first_armed));
  // A transient fault (a communication gap) holds the output at zero for a
  // while and clears by itself; a hard fault needs a re-arm: the check failed.
  std::uint64_t transient_periods = 0;
  std::uint64_t hard_periods = 0;
  for (const auto& row : rows) {
    if (row.fault == hx::SafetyFault::kNone) continue;
    ++(hx::IsTransient(row.fault) ? transient_periods : hard_periods);
  }
  WriteCsv(options.csv_path, rows);
  if (transient_periods > 0) {
    std::cerr << kName << ": " << transient_periods << " of " << rows.size()
              << " periods held at zero output by transient faults\n";
  }
  if (hard_periods > 0) {
    std::cerr << kName << ": " << hard_periods << " of " << rows.size()
              << " periods in the safe state (last fault: " << hx::ToString(rows.back().fault)
              << ")\n";
  }
  PrintSummary(options, rows);
  return hard_periods > 0 ? 1 : 0;
}

}  // namespace ves::station
