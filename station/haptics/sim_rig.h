#pragma once

// Station + simulated VES-IV on the two ends of a socketpair "bus".
//  SimulatedRig: simulated time. Each Step() runs one HapticCycle at t, then
//    lets the device handle what was sent (RPDO1, SYNC) and answer, then
//    advances t by one period: deterministic, as fast as the CPU allows, and
//    used by the tests and by `haptic-check --clock sim`.
//  SimulatedDeviceThread: the device served on its own thread against the
//    wall clock, for the real 1 kHz HapticLoop (bench, `haptic-check`).
#include <atomic>
#include <memory>
#include <thread>

#include "station/haptics/haptic_cycle.h"
#include "station/haptics/simulated_ball_drive.h"
#include "station/haptics/ves4_device.h"

namespace ves::haptics {

struct SimulatedRigOptions {
  SimulatedBallDriveOptions device{};
  Ves4DeviceOptions driver{};
  CycleOptions cycle{};
};

class SimulatedRig {
 public:
  // `source` is needed for the coupled mode only.
  explicit SimulatedRig(SimulatedRigOptions options, BaseResponseSource* source = nullptr);

  // NMT start, then periods until the device is operational and its PDOs
  // arrive, then re-arm. False if that did not happen within max_periods.
  bool BringUp(int max_periods = 200);
  // One period at now_s(); returns what the cycle wrote.
  const CycleOutput& Step();
  void Rearm() { cycle_->Rearm(); }

  double now_s() const { return now_s_; }
  Ves4Device& driver() { return *driver_; }
  SimulatedBallDrive& device() { return *device_; }
  HapticCycle& cycle() { return *cycle_; }

 private:
  SimulatedRigOptions options_;
  std::unique_ptr<Ves4Device> driver_;
  std::unique_ptr<SimulatedBallDrive> device_;
  std::unique_ptr<HapticCycle> cycle_;
  double now_s_{0.0};
};

// Serves a SimulatedBallDrive against CLOCK_MONOTONIC on its own thread.
class SimulatedDeviceThread {
 public:
  SimulatedDeviceThread(SimulatedBallDrive* device, bool realtime, int realtime_priority = 79);
  ~SimulatedDeviceThread();
  SimulatedDeviceThread(const SimulatedDeviceThread&) = delete;
  SimulatedDeviceThread& operator=(const SimulatedDeviceThread&) = delete;
  void Stop();

 private:
  SimulatedBallDrive* device_;
  std::atomic<bool> running_{true};
  std::thread thread_;
};

// Wall-clock bring-up of a driver whose device is served elsewhere: NMT start,
// wait (polling, up to timeout_s) for an operational heartbeat and PDOs.
// Runs before the loop starts; the HapticCycle then takes over the driver.
bool BringUpDevice(Ves4Device* driver, DeviceState* state, double timeout_s);

}  // namespace ves::haptics
