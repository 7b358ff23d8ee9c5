// haptic_loop_bench: the real 1 kHz haptic loop (HapticLoop: clock_nanosleep
// on absolute deadlines, SCHED_FIFO + mlockall when permitted) driving the
// simulated VES-IV over the socketpair bus in coupled mode. The model in the
// loop is either the endoscope-colon model (--model tube: the default 48-link
// scope in a 130-point colon with a 90° bend, one model Step per period) or a
// stand-in that burns --model-load-us per period (--model synthetic).
// Prints the period error percentiles (wake-up minus deadline), overruns and
// the model's time per period.
// The loop sleeps to the deadline minus a margin that follows the recent
// sleep overshoot within [--spin-margin-us, --spin-margin-max-us] and spins
// the rest (both 0: sleeps all the way, the loop as it was before the spin);
// the sleep's own overshoot and the margin used are printed too, to show
// where the period error comes from.
//   haptic_loop_bench [--seconds 30] [--model tube|synthetic] [--model-load-us 20]
//                     [--spin-margin-us 100] [--spin-margin-max-us 600]
//                     [--cpu-latency-us -1] [--no-realtime]
// --cpu-latency-us -1 leaves the CPU idle states alone (no /dev/cpu_dma_latency request).
#include <boost/program_options.hpp>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <string>
#include <memory>
#include <numbers>
#include <thread>
#include <vector>

#include "station/haptics/haptic_loop.h"
#include "station/haptics/model_base_response.h"
#include "station/haptics/realtime.h"
#include "station/haptics/sim_rig.h"

namespace {

namespace hx = ves::haptics;
namespace po = boost::program_options;

// Stands in for the model step: spins for `load_ns` per call and returns a
// soft wall 50 mm in, so the coupled controller has real work to render.
class SyntheticModelLoad final : public hx::BaseResponseSource {
 public:
  explicit SyntheticModelLoad(long long load_ns) : load_ns_(load_ns) {}
  hx::BaseResponse Update(double insertion_m, double /*roll_rad*/, double /*dt_s*/) override {
    const long long start = hx::MonotonicNanoseconds();
    volatile double sink = 0.0;
    while (hx::MonotonicNanoseconds() - start < load_ns_)
      sink = sink + std::sqrt(insertion_m + 2.0);
    hx::BaseResponse response;
    response.update_count = ++count_;
    const double penetration_m = insertion_m - 0.05;
    response.thrust_force_N = penetration_m > 0.0 ? -200.0 * penetration_m : 0.0;
    return response;
  }

 private:
  long long load_ns_;
  std::uint64_t count_{0};
};

// Times each Update of the wrapped source (the model's share of the period).
class TimedSource final : public hx::BaseResponseSource {
 public:
  explicit TimedSource(hx::BaseResponseSource* inner) : inner_(inner) {}
  hx::BaseResponse Update(double insertion_m, double roll_rad, double dt_s) override {
    const long long start = hx::MonotonicNanoseconds();
    const hx::BaseResponse response = inner_->Update(insertion_m, roll_rad, dt_s);
    const long long elapsed = hx::MonotonicNanoseconds() - start;
    total_ns_ += elapsed;
    max_ns_ = std::max(max_ns_, elapsed);
    ++calls_;
    return response;
  }
  double mean_us() const { return calls_ == 0 ? 0.0 : total_ns_ / 1000.0 / calls_; }
  double max_us() const { return max_ns_ / 1000.0; }

 private:
  hx::BaseResponseSource* inner_;
  long long total_ns_{0};
  long long max_ns_{0};
  long long calls_{0};
};

// The default colonoscope in a rigid-walled tube: 150 mm straight, a 90° bend
// of 50 mm radius, 300 mm straight; a point every 4 mm (~130 points).
ves::model::ModelParams BendTubeModel() {
  ves::model::TissueParams tissue;
  tissue.suspension_stiffness_N_per_m2 = 2.0e4;
  tissue.suspension_damping_N_s_per_m2 = 50.0;
  tissue.wall_stiffness_N_per_m = 2000.0;
  tissue.wall_damping_N_s_per_m = 0.5;
  tissue.deformation_threshold_m = 0.005;
  tissue.static_friction = 0.3;
  tissue.dynamic_friction = 0.2;
  tissue.neighbor_tension_N = 1.0;
  std::vector<Eigen::Vector3d> points;
  const double spacing_m = 0.004;
  const double entry_m = 0.15;
  const double bend_radius_m = 0.05;
  const double theta_rad = std::numbers::pi / 2.0;
  for (double s = 0.0; s < entry_m; s += spacing_m) points.emplace_back(0.0, 0.0, s);
  const Eigen::Vector3d center(0.0, bend_radius_m, entry_m);
  for (double phi = 0.0; phi < theta_rad; phi += spacing_m / bend_radius_m) {
    points.push_back(center + bend_radius_m * Eigen::Vector3d(0.0, -std::cos(phi), std::sin(phi)));
  }
  const Eigen::Vector3d end = center + Eigen::Vector3d(0.0, 0.0, bend_radius_m);
  for (double s = 0.0; s <= 0.30; s += spacing_m)
    points.push_back(end + Eigen::Vector3d(0.0, s, 0.0));
  ves::model::ModelParams params;
  params.colon = ves::model::MakeColonFromPoints(points, 0.015, tissue);
  params.thrust_damping_N_s_per_m = 5.0;
  return params;
}

// "1.23 0.98 0.75 ..." from /proc/loadavg: how busy the machine was.
std::string ReadLoadAverage() {
  std::ifstream in("/proc/loadavg");
  std::string line;
  std::getline(in, line);
  return line + "\n";
}

}  // namespace

int main(int argc, char** argv) {
  double seconds = 30.0;
  double load_us = 20.0;
  double spin_margin_us = hx::LoopOptions{}.spin_margin_s * 1e6;
  double spin_margin_max_us = hx::LoopOptions{}.spin_margin_max_s * 1e6;
  int cpu_latency_us = hx::LoopOptions{}.cpu_latency_us;
  std::string model_name = "tube";
  po::options_description description("usage: haptic_loop_bench [options]");
  description.add_options()("help,h", "show this help")(
      "seconds", po::value(&seconds)->default_value(30.0), "run time, s")(
      "model-load-us", po::value(&load_us)->default_value(20.0),
      "synthetic model compute per period, µs")("model",
                                                po::value(&model_name)->default_value("tube"),
                                                "tube (the endoscope-colon model) or synthetic")(
      "spin-margin-us", po::value(&spin_margin_us)->default_value(spin_margin_us),
      "least spin margin (sleep to the deadline minus the margin, spin the rest)")(
      "spin-margin-max-us", po::value(&spin_margin_max_us)->default_value(spin_margin_max_us),
      "largest spin margin; both 0: no spinning")(
      "cpu-latency-us", po::value(&cpu_latency_us)->default_value(cpu_latency_us),
      "hold the CPU wake-up latency (PM QoS) at or below this; -1: do not")(
      "no-realtime", "do not try SCHED_FIFO/mlockall");
  po::variables_map values;
  try {
    po::store(po::parse_command_line(argc, argv, description), values);
    po::notify(values);
  } catch (const po::error& error) {
    std::cerr << "haptic_loop_bench: " << error.what() << "\n";
    return 2;
  }
  if (values.count("help")) {
    std::cout << description << "\n";
    return 0;
  }
  if (!(seconds > 0.0 && seconds <= 3600.0) || !(load_us >= 0.0 && load_us < 900.0) ||
      !(spin_margin_us >= 0.0 && spin_margin_max_us >= spin_margin_us &&
        spin_margin_max_us < 1000.0)) {
    std::cerr << "haptic_loop_bench: --seconds must be in (0, 3600], --model-load-us in "
                 "[0, 900) and 0 <= --spin-margin-us <= --spin-margin-max-us < 1000\n";
    return 2;
  }
  if (model_name != "tube" && model_name != "synthetic") {
    std::cerr << "haptic_loop_bench: --model must be tube or synthetic, got '" << model_name
              << "'\n";
    return 2;
  }
  const bool realtime = values.count("no-realtime") == 0;
  const std::string load_before = ReadLoadAverage();
  std::unique_ptr<hx::BaseResponseSource> model;
  if (model_name == "tube") {
    // The device's zero is 100 mm in; the hand moves ±30 mm about 130 mm.
    model = std::make_unique<hx::ModelBaseResponse>(BendTubeModel(), 0.10);
  } else {
    model = std::make_unique<SyntheticModelLoad>(static_cast<long long>(load_us * 1000.0));
  }
  TimedSource timed_model(model.get());

  auto [host, bus_device] = hx::CanBus::CreateSocketPair();
  hx::SimulatedBallDriveOptions device_options;
  device_options.hand.thrust.amplitude = 0.03;
  device_options.hand.thrust.frequency_Hz = 0.5;
  device_options.hand.thrust.offset = 0.03;  // synthetic: into its wall at 50 mm
  hx::Ves4Device driver(std::move(host), device_options.params);
  hx::SimulatedBallDrive device(std::move(bus_device), device_options);
  hx::SimulatedDeviceThread device_thread(&device, realtime);
  hx::DeviceState state;
  if (!hx::BringUpDevice(&driver, &state, 2.0)) {
    std::cerr << "haptic_loop_bench: simulated device did not come up\n";
    return 1;
  }
  hx::CycleOptions cycle_options;
  cycle_options.control.mode = hx::ControlMode::kCoupled;
  hx::HapticCycle cycle(&driver, &timed_model, cycle_options);
  cycle.SetInitialDeviceState(state);
  hx::LoopOptions loop_options;
  loop_options.realtime = realtime;
  loop_options.spin_margin_s = spin_margin_us * 1e-6;
  loop_options.spin_margin_max_s = spin_margin_max_us * 1e-6;
  loop_options.cpu_latency_us = cpu_latency_us;
  hx::HapticLoop loop(&cycle, loop_options);
  loop.Start();
  if (!loop.ArmAfter(20, 2.0)) {
    std::cerr << "haptic_loop_bench: the loop did not start\n";
    return 1;
  }
  std::this_thread::sleep_for(std::chrono::duration<double>(seconds));
  loop.Stop();
  device_thread.Stop();

  const hx::LoopStats& stats = loop.stats();
  const auto us = [](std::int64_t ns) { return static_cast<double>(ns) / 1000.0; };
  const hx::DeviceCounters counters = driver.counters();
  if (model_name == "tube") {
    std::printf("haptic_loop_bench: %.0f s, model=tube (station/model Step in the loop), %s\n",
                seconds, realtime ? "realtime requested" : "normal scheduling");
  } else {
    std::printf("haptic_loop_bench: %.0f s, model=synthetic %.0f us/period, %s\n", seconds, load_us,
                realtime ? "realtime requested" : "normal scheduling");
  }
  std::printf("spin_margin_us=[%.0f, %.0f] cpu_latency_us=%d load_before=%s", spin_margin_us,
              spin_margin_max_us, cpu_latency_us, load_before.c_str());
  std::printf("model_us mean=%.1f max=%.1f\n", timed_model.mean_us(), timed_model.max_us());
  std::printf("cycles=%llu overruns=%llu\n", static_cast<unsigned long long>(stats.cycles),
              static_cast<unsigned long long>(stats.overruns));
  std::printf("period_error_us p50=%.0f p99=%.0f p99.9=%.0f max=%.1f\n",
              us(stats.period_error.PercentileNs(0.5)), us(stats.period_error.PercentileNs(0.99)),
              us(stats.period_error.PercentileNs(0.999)), us(stats.period_error.max_ns()));
  std::printf("sleep_overshoot_us p50=%.0f p99=%.0f p99.9=%.0f max=%.1f (sleeps=%llu)\n",
              us(stats.sleep_overshoot.PercentileNs(0.5)),
              us(stats.sleep_overshoot.PercentileNs(0.99)),
              us(stats.sleep_overshoot.PercentileNs(0.999)), us(stats.sleep_overshoot.max_ns()),
              static_cast<unsigned long long>(stats.sleep_overshoot.count()));
  std::printf("spin_margin_used_us p50=%.0f p99=%.0f max=%.1f\n",
              us(stats.spin_margin.PercentileNs(0.5)), us(stats.spin_margin.PercentileNs(0.99)),
              us(stats.spin_margin.max_ns()));
  std::printf(
      "frames_sent=%llu frames_received=%llu lost_frames=%llu transient_faults=%llu "
      "hard_faults=%llu last_fault=%s\n",
      static_cast<unsigned long long>(counters.frames_sent),
      static_cast<unsigned long long>(counters.frames_received),
      static_cast<unsigned long long>(counters.lost_frames),
      static_cast<unsigned long long>(cycle.safety().transient_faults()),
      static_cast<unsigned long long>(cycle.safety().hard_faults()),
      hx::ToString(cycle.safety().fault()));
  return 0;
}
