#include "station/haptics/haptic_loop.h"

#include <algorithm>
#include <chrono>
#include <ctime>
#include <optional>
#include <stdexcept>
#include <string>

#include "station/haptics/realtime.h"

namespace ves::haptics {
namespace {

constexpr long long kNanosPerSecond = 1000000000LL;

timespec ToTimespec(long long ns) {
  return timespec{static_cast<time_t>(ns / kNanosPerSecond),
                  static_cast<long>(ns % kNanosPerSecond)};
}

// Per period: the overshoot peak halves in ln(2)/(1 − 0.999) ≈ 690 periods.
constexpr double kOvershootPeakDecay = 0.999;

// Tells the core we are spinning (x86 PAUSE): kinder to a hyperthread sibling.
inline void SpinPause() {
#if defined(__x86_64__) || defined(__i386__)
  __builtin_ia32_pause();
#endif
}

}  // namespace

HapticSnapshot MakeSnapshot(std::uint64_t cycle, double t_s, const DeviceState& device,
                            const CycleOutput& output) {
  HapticSnapshot snapshot;
  snapshot.cycle = cycle;
  snapshot.t_s = t_s;
  snapshot.insertion_m = device.insertion_m;
  snapshot.roll_rad = device.roll_rad;
  snapshot.force_N = device.force_N;
  snapshot.torque_Nm = device.torque_Nm;
  snapshot.thrust_command_N = output.command.thrust_force_N;
  snapshot.roll_command_Nm = output.command.roll_torque_Nm;
  snapshot.base_thrust_force_N = output.base.thrust_force_N;
  snapshot.base_roll_torque_Nm = output.base.roll_torque_Nm;
  snapshot.fault = output.fault;
  snapshot.output_scale = output.output_scale;
  return snapshot;
}

HapticLoop::HapticLoop(HapticCycle* cycle, LoopOptions options, SpscRing<HapticSnapshot>* trace)
    : cycle_(cycle), options_(options), trace_(trace) {
  if (cycle_ == nullptr) throw std::invalid_argument("HapticLoop needs a cycle");
  if (!(options_.period_s >= 1e-4 && options_.period_s <= 1.0)) {
    throw std::invalid_argument("HapticLoop period_s must be in [1e-4, 1], got " +
                                std::to_string(options_.period_s));
  }
  if (!(options_.spin_margin_s >= 0.0 && options_.spin_margin_max_s >= options_.spin_margin_s &&
        options_.spin_margin_max_s < options_.period_s && options_.spin_guard_s >= 0.0)) {
    throw std::invalid_argument(
        "HapticLoop needs 0 <= spin_margin_s <= spin_margin_max_s < period_s and "
        "spin_guard_s >= 0, got " +
        std::to_string(options_.spin_margin_s) + ", " +
        std::to_string(options_.spin_margin_max_s) + ", " + std::to_string(options_.spin_guard_s));
  }
}

HapticLoop::~HapticLoop() { Stop(); }

bool HapticLoop::ArmAfter(std::uint64_t periods, double timeout_s) {
  const std::uint64_t target = cycles() + periods;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  while (cycles() < target) {
    if (std::chrono::steady_clock::now() > deadline) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  RequestRearm();
  return true;
}

void HapticLoop::Start() {
  if (running_.exchange(true)) return;
  thread_ = std::thread([this] { Main(); });
}

void HapticLoop::Stop() {
  running_.store(false, std::memory_order_release);
  if (thread_.joinable()) thread_.join();
}

void HapticLoop::Main() {
  if (options_.realtime) TryEnableRealtime(options_.realtime_priority, "haptic loop");
  std::optional<CpuLatencyRequest> latency;
  if (options_.realtime && options_.cpu_latency_us >= 0) latency.emplace(options_.cpu_latency_us);
  const auto period_ns = static_cast<long long>(options_.period_s * 1e9 + 0.5);
  const auto min_margin_ns = static_cast<long long>(options_.spin_margin_s * 1e9 + 0.5);
  const auto max_margin_ns = static_cast<long long>(options_.spin_margin_max_s * 1e9 + 0.5);
  const auto guard_ns = static_cast<long long>(options_.spin_guard_s * 1e9 + 0.5);
  double overshoot_peak_ns = 0.0;  // decaying peak of the sleeps' overshoot
  long long deadline_ns = MonotonicNanoseconds() + period_ns;
  while (running_.load(std::memory_order_acquire)) {
    const long long margin_ns = std::clamp(
        static_cast<long long>(overshoot_peak_ns) + guard_ns, min_margin_ns, max_margin_ns);
    stats_.spin_margin.Add(margin_ns);
    const long long sleep_target_ns = deadline_ns - margin_ns;
    long long wake_ns = MonotonicNanoseconds();
    if (wake_ns < sleep_target_ns) {
      const timespec target = ToTimespec(sleep_target_ns);
      while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &target, nullptr) == EINTR) {
      }
      wake_ns = MonotonicNanoseconds();
      const long long overshoot_ns = wake_ns - sleep_target_ns;
      stats_.sleep_overshoot.Add(overshoot_ns);
      // A stall of milliseconds (host preemption) counts as the cap, so the
      // margin comes back down within about a second after it.
      overshoot_peak_ns = std::max(static_cast<double>(std::min(overshoot_ns, max_margin_ns)),
                                   overshoot_peak_ns * kOvershootPeakDecay);
    }
    while (wake_ns < deadline_ns) {
      SpinPause();
      wake_ns = MonotonicNanoseconds();
    }
    stats_.period_error.Add(wake_ns - deadline_ns);
    if (rearm_requested_.exchange(false, std::memory_order_acq_rel)) cycle_->Rearm();
    const double now_s = static_cast<double>(wake_ns) * 1e-9;
    const CycleOutput& output = cycle_->Run(now_s);
    const std::uint64_t cycle = stats_.cycles++;
    const HapticSnapshot snapshot = MakeSnapshot(cycle, now_s, cycle_->device_state(), output);
    latest_.Store(snapshot);
    if (trace_ != nullptr) trace_->Push(snapshot);
    cycles_.store(stats_.cycles, std::memory_order_relaxed);
    deadline_ns += period_ns;
    const long long end_ns = MonotonicNanoseconds();
    stats_.cycle_end.Add(end_ns - (deadline_ns - period_ns));
    if (end_ns > deadline_ns) {
      ++stats_.overruns;
      // Skip the deadlines already missed rather than running them back to back.
      while (deadline_ns < end_ns) deadline_ns += period_ns;
    }
  }
}

}  // namespace ves::haptics
