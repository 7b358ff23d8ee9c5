#include "station/haptics/sim_rig.h"

#include <chrono>
#include <stdexcept>

#include "station/haptics/realtime.h"

namespace ves::haptics {

SimulatedRig::SimulatedRig(SimulatedRigOptions options, BaseResponseSource* source)
    : options_(options) {
  auto [host, device] = CanBus::CreateSocketPair();
  options_.driver.period_s = options_.cycle.period_s;
  options_.device.period_s = options_.cycle.period_s;
  driver_ = std::make_unique<Ves4Device>(std::move(host), options_.device.params, options_.driver);
  device_ = std::make_unique<SimulatedBallDrive>(std::move(device), options_.device);
  cycle_ = std::make_unique<HapticCycle>(driver_.get(), source, options_.cycle);
}

bool SimulatedRig::BringUp(int max_periods) {
  device_->Service(now_s_);  // boot-up heartbeat
  driver_->SendNmt(now_s_, NmtCommandSpecifier::kStart);
  for (int i = 0; i < max_periods; ++i) {
    Step();
    const DeviceState& state = cycle_->device_state();
    if (state.device_nmt_state == NmtState::kOperational &&
        state.last_sensor_time_s == state.last_encoder_time_s &&
        now_s_ - state.last_sensor_time_s <= options_.cycle.period_s * 1.5) {
      cycle_->Rearm();
      return true;
    }
  }
  return false;
}

const CycleOutput& SimulatedRig::Step() {
  const CycleOutput& output = cycle_->Run(now_s_);
  device_->Service(now_s_);
  now_s_ += options_.cycle.period_s;
  return output;
}

void SimulatedRig::StallStation(double seconds) {
  const double end_s = now_s_ + seconds;
  while (now_s_ < end_s) {
    device_->Service(now_s_);
    now_s_ += options_.cycle.period_s;
  }
}

SimulatedDeviceThread::SimulatedDeviceThread(SimulatedBallDrive* device, bool realtime,
                                             int realtime_priority)
    : device_(device) {
  thread_ = std::thread([this, realtime, realtime_priority] {
    if (realtime) TryEnableRealtime(realtime_priority, "simulated device");
    while (running_.load(std::memory_order_acquire)) {
      device_->ServiceWait(2, MonotonicSeconds());
    }
  });
}

SimulatedDeviceThread::~SimulatedDeviceThread() { Stop(); }

void SimulatedDeviceThread::Stop() {
  running_.store(false, std::memory_order_release);
  if (thread_.joinable()) thread_.join();
}

InlineSimulatedDevice::InlineSimulatedDevice(Ves4Device* driver, SimulatedBallDrive* device)
    : driver_(driver), device_(device) {
  if (driver_ == nullptr || device_ == nullptr) {
    throw std::invalid_argument("InlineSimulatedDevice needs a driver and a device");
  }
}

void InlineSimulatedDevice::Write(double now_s, const MotorCommand& command) {
  driver_->Write(now_s, command);
  if (before_service_) before_service_(now_s, device_);
  device_->Service(now_s);
}

bool BringUpDevice(HapticDevice* driver, DeviceState* state, double timeout_s) {
  const double start_s = MonotonicSeconds();
  driver->Enable(start_s);
  // Unpowered SYNCs so the device answers with PDOs once operational.
  while (MonotonicSeconds() - start_s < timeout_s) {
    const double now_s = MonotonicSeconds();
    driver->Read(now_s, state);
    if (state->device_nmt_state == NmtState::kOperational &&
        now_s - state->last_sensor_time_s < 0.01 && now_s - state->last_encoder_time_s < 0.01) {
      return true;
    }
    driver->Write(now_s, MotorCommand{});
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  return false;
}

}  // namespace ves::haptics
