#pragma once

#include <memory>
#include <string>

#include "station/app/run_interactive.h"
#include "station/haptics/candump_log.h"
#include "station/haptics/device.h"
#include "station/haptics/keyboard_push.h"
#include "station/haptics/seqlock.h"
#include "station/haptics/sim_rig.h"
#include "station/haptics/simulated_ball_drive.h"
#include "station/haptics/ves4_device.h"

// The device bring-up of an interactive run (docs/station-run.md,
// "Interactive mode"): the bus, the driver, the simulated device and its
// keyboard hand, the CAN log.
namespace ves::station {

// UI -> simulated hand: where the keyboard wants the scope (device coordinates).
struct HandTarget {
  double insertion_m{0.0};
  double roll_rad{0.0};
};

// The simulated hand on the keyboard's target: it follows no faster than a
// person pushes a colonoscope, with a force that ramps and is bounded to what
// a hand gives (haptics::KeyboardPush, docs/station-ui.md).
class KeyboardHand {
 public:
  KeyboardHand(const haptics::SeqLock<HandTarget>* target, double period_s)
      : target_(target), push_(haptics::KeyboardPushCurve{}, period_s) {}
  void Move(haptics::SimulatedBallDrive* device) {
    HandTarget target;
    target_->Load(&target);
    device->set_hand(push_.Next(target.insertion_m, target.roll_rad, device->plant().insertion_m));
  }

 private:
  const haptics::SeqLock<HandTarget>* target_;
  haptics::KeyboardPush push_;
};

// The bus (SocketCAN to the real VES-IV, or a socketpair to the simulated
// one served on the loop's thread, its hand on the keyboard), the driver,
// the candump log. The constructor brings the device up; it throws
// std::runtime_error when the device does not become operational in 2 s.
class InteractiveRig {
 public:
  InteractiveRig(InteractiveDevice device, double period_s,
                 const haptics::SeqLock<HandTarget>* hand_target);

  haptics::HapticDevice* device() { return device_; }
  const haptics::DeviceState& initial_state() const { return initial_state_; }
  bool simulated() const { return simulated_; }
  const std::string& bus_name() const { return bus_name_; }
  std::string label() const { return simulated_ ? "sim" : "can:" + bus_name_; }
  void CloseLog() {
    if (recorder_) recorder_->Close();
  }

 private:
  bool simulated_;
  std::string bus_name_;
  KeyboardHand keyboard_hand_;
  std::unique_ptr<haptics::Ves4Device> driver_;
  std::unique_ptr<haptics::CanFrameRecorder> recorder_;
  std::unique_ptr<haptics::SimulatedBallDrive> simulated_device_;
  std::unique_ptr<haptics::InlineSimulatedDevice> inline_device_;
  haptics::HapticDevice* device_{nullptr};
  haptics::DeviceState initial_state_;
};

}  // namespace ves::station
