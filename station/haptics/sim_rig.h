#pragma once

// Station + simulated VES-IV on the two ends of a socketpair "bus".
//  SimulatedRig: simulated time. Each Step() runs one HapticCycle at t, then
//    lets the device handle what was sent (RPDO1, SYNC) and answer, then
//    advances t by one period: deterministic, as fast as the CPU allows, and
//    used by the tests and by `haptic-check --clock sim`.
//  InlineSimulatedDevice: the station's driver with the device served right
//    after each Write(), on the loop's own thread, for the real 1 kHz
//    HapticLoop (`haptic-check`, interactive `run` with --device sim).
//  SimulatedDeviceThread: the device served on its own thread against the
//    wall clock (bench, and tests of a device that runs on while the loop
//    thread stalls).
#include <atomic>
#include <functional>
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
  // The station's loop does not run for `seconds` while the device, its own
  // hardware, keeps running (a real VES-IV while the station is descheduled).
  void StallStation(double seconds);
  // Neither runs for `seconds`: the whole process was stopped (the simulated
  // device lives in the station's process).
  void StallAll(double seconds) { now_s_ += seconds; }

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

// The driver with the simulated VES-IV behind it, served on the caller's
// thread: each Write() (RPDO1, SYNC, heartbeat) is followed at once by the
// device handling those frames and answering (TPDO1, TPDO2), which the next
// Read() picks up — the timing of the real device, whose own hardware answers
// a SYNC within the period whatever the station's PC is doing. A thread of
// its own would let the OS deschedule the simulated firmware apart from the
// loop: a silence no real device has (on the 2-vCPU development VM under a
// CPU hog, 1–2 false sensor timeouts per 10 s run). A stall of the loop's
// thread stops both, as no SYNC goes out.
class InlineSimulatedDevice final : public HapticDevice {
 public:
  // Neither may be null; both must outlive this.
  InlineSimulatedDevice(Ves4Device* driver, SimulatedBallDrive* device);

  void Read(double now_s, DeviceState* state) override { driver_->Read(now_s, state); }
  void Write(double now_s, const MotorCommand& command) override;
  void SendEmergency(double now_s, EmcyCode code) override { driver_->SendEmergency(now_s, code); }
  void Enable(double now_s) override { driver_->Enable(now_s); }
  void ClearFaultFlags(DeviceState* state) override { driver_->ClearFaultFlags(state); }
  DeviceCounters counters() const override { return driver_->counters(); }

  // Called on the loop thread before the device is served (e.g. to move the
  // simulated hand); must not block. Set before the loop starts.
  void set_before_service(std::function<void(double now_s, SimulatedBallDrive*)> hook) {
    before_service_ = std::move(hook);
  }

 private:
  Ves4Device* driver_;
  SimulatedBallDrive* device_;
  std::function<void(double, SimulatedBallDrive*)> before_service_;
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

// Wall-clock bring-up: NMT start, then unpowered periods (polling, up to
// timeout_s) until an operational heartbeat and PDOs arrive. Runs before the
// loop starts; the HapticCycle then takes over the device.
bool BringUpDevice(HapticDevice* device, DeviceState* state, double timeout_s);

}  // namespace ves::haptics
