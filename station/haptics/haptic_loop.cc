#include "station/haptics/haptic_loop.h"

#include <chrono>
#include <ctime>
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
  return snapshot;
}

HapticLoop::HapticLoop(HapticCycle* cycle, LoopOptions options, SpscRing<HapticSnapshot>* trace)
    : cycle_(cycle), options_(options), trace_(trace) {
  if (cycle_ == nullptr) throw std::invalid_argument("HapticLoop needs a cycle");
  if (!(options_.period_s >= 1e-4 && options_.period_s <= 1.0)) {
    throw std::invalid_argument("HapticLoop period_s must be in [1e-4, 1], got " +
                                std::to_string(options_.period_s));
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
  const auto period_ns = static_cast<long long>(options_.period_s * 1e9 + 0.5);
  long long deadline_ns = MonotonicNanoseconds() + period_ns;
  while (running_.load(std::memory_order_acquire)) {
    const timespec deadline = ToTimespec(deadline_ns);
    while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &deadline, nullptr) == EINTR) {
    }
    const long long wake_ns = MonotonicNanoseconds();
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
    if (end_ns > deadline_ns) {
      ++stats_.overruns;
      // Skip the deadlines already missed rather than running them back to back.
      while (deadline_ns < end_ns) deadline_ns += period_ns;
    }
  }
}

}  // namespace ves::haptics
