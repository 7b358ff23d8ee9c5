#pragma once

// HapticLoop: runs a HapticCycle at 1 kHz on its own thread, on absolute
// deadlines (CLOCK_MONOTONIC), SCHED_FIFO and mlockall when permitted. Each
// period it sleeps (clock_nanosleep, TIMER_ABSTIME) to the deadline minus a
// spin margin, then spins on the clock to the deadline: a sleeping core — on a
// VM, a halted vCPU the host has to schedule again — wakes tens to hundreds of
// µs late, the spin absorbs that. It records the period error (start of the
// cycle minus deadline) and the sleep's own overshoot in histograms and counts
// overruns (a period that ends after the
// next deadline; the missed deadlines are skipped, not bunched). Each period's
// state goes to readers through a SeqLock (latest value, e.g. the render
// thread) and an optional SPSC ring (every period, e.g. a CSV writer).
#include <atomic>
#include <cstdint>
#include <thread>

#include "station/haptics/haptic_cycle.h"
#include "station/haptics/period_histogram.h"
#include "station/haptics/seqlock.h"
#include "station/haptics/spsc_ring.h"

namespace ves::haptics {

// What a render or UI thread needs from the loop, published every period.
struct HapticSnapshot {
  std::uint64_t cycle{0};
  double t_s{0.0};
  double insertion_m{0.0};
  double roll_rad{0.0};
  double force_N{0.0};
  double torque_Nm{0.0};
  double thrust_command_N{0.0};
  double roll_command_Nm{0.0};
  double base_thrust_force_N{0.0};
  double base_roll_torque_Nm{0.0};
  SafetyFault fault{SafetyFault::kNotArmed};
  double output_scale{0.0};  // 1: full output; below 1: fading in after a transient fault
};

HapticSnapshot MakeSnapshot(std::uint64_t cycle, double t_s, const DeviceState& device,
                            const CycleOutput& output);

struct LoopOptions {
  double period_s{0.001};
  bool realtime{true};  // try SCHED_FIFO + mlockall
  int realtime_priority{80};
  // Sleep ends a margin before the deadline; the rest is spun. The margin
  // follows the sleeps' recent overshoot (a peak that decays by half every
  // ~0.7 s) plus spin_guard_s, kept within [spin_margin_s, spin_margin_max_s]:
  // little spinning when wake-ups are prompt, up to the cap under load.
  // Both 0: sleep to the deadline (no spinning). Both must be below period_s.
  double spin_margin_s{100e-6};
  double spin_margin_max_s{600e-6};
  double spin_guard_s{50e-6};
  // With realtime: hold the CPUs' wake-up latency at or below this while the
  // loop runs (CpuLatencyRequest); negative (default): leave the idle states
  // alone — on the development VM it made no measurable difference (the
  // wake-up delay there is the hypervisor's timer path, not a C-state exit).
  int cpu_latency_us{-1};
};

struct LoopStats {
  PeriodHistogram period_error{};
  PeriodHistogram sleep_overshoot{};  // wake-up minus the sleep's own target
  PeriodHistogram spin_margin{};      // the margin used, per period
  // Deadline to the end of that period's cycle (late start plus the cycle's
  // work): over the period, the cycle overran (station health, docs/station-run.md).
  PeriodHistogram cycle_end{};
  std::uint64_t cycles{0};
  std::uint64_t overruns{0};
};

class HapticLoop {
 public:
  // `trace` may be null; the cycle must outlive the loop.
  HapticLoop(HapticCycle* cycle, LoopOptions options, SpscRing<HapticSnapshot>* trace = nullptr);
  ~HapticLoop();
  HapticLoop(const HapticLoop&) = delete;
  HapticLoop& operator=(const HapticLoop&) = delete;

  void Start();
  void Stop();
  // Asks the loop thread to re-arm at its next period.
  void RequestRearm() { rearm_requested_.store(true, std::memory_order_release); }
  // Start-up: waits (up to timeout_s) until the loop has run `periods`
  // periods, so SYNCs have fetched fresh samples, then requests the re-arm.
  // False if the loop did not get that far.
  bool ArmAfter(std::uint64_t periods, double timeout_s);

  const SeqLock<HapticSnapshot>& latest() const { return latest_; }
  // Valid after Stop().
  const LoopStats& stats() const { return stats_; }
  std::uint64_t cycles() const { return cycles_.load(std::memory_order_relaxed); }

 private:
  void Main();

  HapticCycle* cycle_;
  LoopOptions options_;
  SpscRing<HapticSnapshot>* trace_;
  SeqLock<HapticSnapshot> latest_;
  LoopStats stats_;
  std::atomic<std::uint64_t> cycles_{0};
  std::atomic<bool> running_{false};
  std::atomic<bool> rearm_requested_{false};
  std::thread thread_;
};

}  // namespace ves::haptics
