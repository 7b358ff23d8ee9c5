// The wall-clock loop and its pieces. No timing assertions here: the loop's
// speed is measured by bench/haptics/haptic_loop_bench.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <thread>

#include "station/haptics/haptic_loop.h"
#include "station/haptics/line_fit.h"
#include "station/haptics/period_histogram.h"
#include "station/haptics/seqlock.h"
#include "station/haptics/sim_rig.h"

namespace ves::haptics {
namespace {

struct Triple {
  double a{0.0};
  double b{0.0};
  double c{0.0};
  std::uint64_t n{0};
};

TEST(SeqLock, ReaderNeverSeesATornValue) {
  SeqLock<Triple> lock;
  std::atomic<bool> done{false};
  std::atomic<bool> stop{false};
  constexpr std::uint64_t kMaxStores = 50000000;
  std::atomic<std::uint64_t> stores{0};
  std::thread writer([&] {
    std::uint64_t i = 1;
    for (; i <= kMaxStores && !stop.load(std::memory_order_relaxed); ++i) {
      const double v = static_cast<double>(i);
      lock.Store({v, 2.0 * v, 3.0 * v, i});
    }
    stores.store(i - 1);
    done.store(true);
  });
  std::uint64_t reads = 0;
  std::uint64_t last_n = 0;
  while (!done.load()) {
    if (reads >= 20000) stop.store(true);
    Triple t;
    if (!lock.Load(&t)) continue;
    ++reads;
    ASSERT_EQ(t.b, 2.0 * t.a);
    ASSERT_EQ(t.c, 3.0 * t.a);
    ASSERT_EQ(static_cast<double>(t.n), t.a);
    ASSERT_GE(t.n, last_n);  // never goes back in time
    last_n = t.n;
  }
  writer.join();
  Triple final_value;
  ASSERT_TRUE(lock.Load(&final_value));
  EXPECT_EQ(final_value.n, stores.load());
  EXPECT_GT(reads, 0u);
}

TEST(PeriodHistogram, PercentilesAtMicrosecondResolution) {
  PeriodHistogram histogram;
  // 990 samples of 5 µs, 9 of 150 µs, one of 2.5 ms.
  for (int i = 0; i < 990; ++i) histogram.Add(5000);
  for (int i = 0; i < 9; ++i) histogram.Add(150000);
  histogram.Add(2500000);
  EXPECT_EQ(histogram.count(), 1000u);
  EXPECT_EQ(histogram.PercentileNs(0.5), 6000);   // upper edge of the 5 µs bin
  EXPECT_EQ(histogram.PercentileNs(0.99), 6000);  // the 990th sample
  EXPECT_EQ(histogram.PercentileNs(0.999), 151000);
  EXPECT_EQ(histogram.PercentileNs(1.0), 2500000);
  EXPECT_EQ(histogram.max_ns(), 2500000);
  histogram.Add(-3000);  // early wake-ups count as 0
  EXPECT_EQ(histogram.count(), 1001u);
}

TEST(LineFit, RecoversAnExactLineAndScoresNoise) {
  // y = 100·x − 0.5: slope 100, R² = 1.
  std::vector<double> x;
  std::vector<double> y;
  for (int i = 0; i < 50; ++i) {
    x.push_back(i * 0.001);
    y.push_back(100.0 * i * 0.001 - 0.5);
  }
  const LineFit fit = FitLine(x, y);
  EXPECT_NEAR(fit.slope, 100.0, 1e-9);
  EXPECT_NEAR(fit.intercept, -0.5, 1e-12);
  EXPECT_NEAR(fit.r2, 1.0, 1e-12);
  // y = ±1 alternating has no linear relation to x: R² near 0.
  for (int i = 0; i < 50; ++i) y[i] = (i % 2 == 0) ? 1.0 : -1.0;
  EXPECT_LT(FitLine(x, y).r2, 0.05);
  const AxisSummary summary = SummarizeAxis(x, y);
  EXPECT_DOUBLE_EQ(summary.rms_load, 1.0);
  EXPECT_DOUBLE_EQ(summary.max_abs_load, 1.0);
  EXPECT_THROW(FitLine({1.0}, {1.0}), std::invalid_argument);
}

TEST(HapticLoop, RunsOnTheWallClockWithTheDeviceOnItsOwnThread) {
  auto [host, bus_device] = CanBus::CreateSocketPair();
  SimulatedBallDriveOptions device_options;
  device_options.hand.thrust.amplitude = 0.01;
  device_options.hand.thrust.frequency_Hz = 1.0;
  Ves4Device driver(std::move(host), device_options.params);
  SimulatedBallDrive device(std::move(bus_device), device_options);
  SimulatedDeviceThread device_thread(&device, /*realtime=*/false);
  DeviceState state;
  ASSERT_TRUE(BringUpDevice(&driver, &state, 2.0));

  CycleOptions cycle_options;
  HapticCycle cycle(&driver, nullptr, cycle_options);
  cycle.SetInitialDeviceState(state);
  SpscRing<HapticSnapshot> trace(4096);
  HapticLoop loop(&cycle, LoopOptions{.realtime = false}, &trace);
  loop.Start();
  ASSERT_TRUE(loop.ArmAfter(20, 5.0));
  // A reader thread's view: the latest snapshot, taken without locks.
  HapticSnapshot latest;
  for (int i = 0; i < 30 && loop.cycles() < 100; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  ASSERT_TRUE(loop.latest().Load(&latest));
  loop.Stop();
  device_thread.Stop();

  EXPECT_GE(loop.stats().cycles, 100u);
  EXPECT_EQ(loop.stats().period_error.count(), loop.stats().cycles);
  // Every cycle's end is counted, and none ends before its own deadline.
  EXPECT_EQ(loop.stats().cycle_end.count(), loop.stats().cycles);
  EXPECT_GE(loop.stats().cycle_end.PercentileNs(0.5), loop.stats().period_error.PercentileNs(0.5));
  EXPECT_GT(latest.cycle, 0u);
  HapticSnapshot popped;
  std::uint64_t popped_count = 0;
  std::uint64_t previous_cycle = 0;
  while (trace.Pop(&popped)) {
    if (popped_count > 0) {
      EXPECT_EQ(popped.cycle, previous_cycle + 1);
    }
    previous_cycle = popped.cycle;
    ++popped_count;
  }
  EXPECT_EQ(popped_count + trace.dropped(), loop.stats().cycles);
  EXPECT_GT(driver.counters().frames_received, 100u);
}

// A model source that stalls the loop thread (sleeps in Update) when asked.
class StallingSource final : public BaseResponseSource {
 public:
  BaseResponse Update(double, double, double) override {
    const int stall_ms = stall_ms_.exchange(0);
    if (stall_ms > 0) std::this_thread::sleep_for(std::chrono::milliseconds(stall_ms));
    return BaseResponse{0.0, 0.0, ++count_};
  }
  void StallOnce(int ms) { stall_ms_.store(ms); }
  bool pending() const { return stall_ms_.load() != 0; }

 private:
  std::atomic<int> stall_ms_{0};
  std::uint64_t count_{0};
};

// The loop thread stops for 20-50 ms while the device thread runs on: the
// device misses the station's heartbeat and cuts its motors. Each stall is a
// transient fault at most; the output comes back without a re-arm. Both
// threads ask for SCHED_FIFO (as the station does): the device thread
// stands for hardware that always answers, and a device starved by the OS
// for 100 ms is a long silence, rightly a hard fault (seen under a loaded
// `ctest -j2` with normal scheduling).
TEST(HapticLoop, StallsOfTheLoopThreadEndWithoutAFaultThatNeedsARearm) {
  auto [host, bus_device] = CanBus::CreateSocketPair();
  SimulatedBallDriveOptions device_options;
  Ves4Device driver(std::move(host), device_options.params);
  SimulatedBallDrive device(std::move(bus_device), device_options);
  SimulatedDeviceThread device_thread(&device, /*realtime=*/true);
  DeviceState state;
  ASSERT_TRUE(BringUpDevice(&driver, &state, 2.0));
  StallingSource source;
  CycleOptions cycle_options;
  cycle_options.control.mode = ControlMode::kCoupled;
  HapticCycle cycle(&driver, &source, cycle_options);
  cycle.SetInitialDeviceState(state);
  HapticLoop loop(&cycle, LoopOptions{.realtime = true});
  loop.Start();
  ASSERT_TRUE(loop.ArmAfter(20, 5.0));
  for (int stall_ms : {20, 30, 50, 30, 40}) {
    std::this_thread::sleep_for(std::chrono::milliseconds(150));
    source.StallOnce(stall_ms);
    while (source.pending()) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  // Time to recover from the last one: healthy for 50 ms, then a 0.3 s fade.
  HapticSnapshot latest;
  for (int i = 0; i < 300; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
    loop.latest().Load(&latest);
    if (latest.fault == SafetyFault::kNone && latest.output_scale == 1.0) break;
  }
  loop.Stop();
  device_thread.Stop();
  EXPECT_EQ(cycle.safety().hard_faults(), 0u) << ToString(cycle.safety().fault());
  EXPECT_EQ(latest.fault, SafetyFault::kNone) << ToString(latest.fault);
  EXPECT_EQ(latest.output_scale, 1.0);
  EXPECT_GE(cycle.safety().stalls(), 5u);
  EXPECT_EQ(cycle.safety().recoveries(), cycle.safety().transient_faults());
}

}  // namespace
}  // namespace ves::haptics
