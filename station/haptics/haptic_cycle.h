#pragma once

// One period of the haptic loop, independent of any clock: read the device,
// ask the model source, check the safety rules, run the mode's controller,
// clamp, write. The wall-clock loop (HapticLoop) and the simulated-time runner
// both call Run() once per period, so tests exercise exactly the loop's code.
// Run() never throws or allocates; the one log line on a fault transition is
// the exception that proves the rule (it happens once per fault).
// In a transient fault (SafetyMonitor) the cycle sends NMT start every
// kEnableRetry_s while the device does not drive its motors, so a device
// that cut them (it lost the station's heartbeat during a stall) comes back
// without a re-arm; when the fault clears, the controller's targets are put
// on the measured state and the command fades in.
#include <cstdint>
#include <optional>

#include "station/haptics/base_response.h"
#include "station/haptics/controllers.h"
#include "station/haptics/device.h"
#include "station/haptics/safety_monitor.h"

namespace ves::haptics {

// The limits of what the motors render at the scope: the one setting of the
// one clamp (ClampCommand in Run). Every command the cycle writes is within
// them; the driver relies on it (HapticDevice::Write).
struct OutputLimits {
  double max_force_N{10.0};
  double max_torque_Nm{0.3};
  bool operator==(const OutputLimits&) const = default;
};

struct CycleOptions {
  double period_s{0.001};
  ControlParams control{};
  SafetyLimits safety{};
  OutputLimits limits{};
};

struct CycleOutput {
  MotorCommand command{};  // what was written this period
  SafetyFault fault{SafetyFault::kNotArmed};
  double output_scale{0.0};  // share of the controller's command sent (fade-in after a transient)
  BaseResponse base{};  // coupled mode: the model response used
  bool operator==(const CycleOutput&) const = default;
};

// Clamps to the limits; NaN/Inf in a value -> 0 and `*non_finite` set.
MotorCommand ClampCommand(const MotorCommand& command, const OutputLimits& limits,
                          bool* non_finite);

class HapticCycle {
 public:
  // `source` is needed for the coupled mode only (may be null otherwise).
  HapticCycle(HapticDevice* device, BaseResponseSource* source, CycleOptions options);

  static constexpr double kEnableRetry_s = 0.020;

  const CycleOutput& Run(double now_s);
  // Leaves the safe state: clears the latched fault and sticky bus flags,
  // puts the controller's targets on the measured state, and has the next
  // Run() send NMT start so a device that cut its motors drives again.
  void Rearm();
  // Starts from what a bring-up already read (times of the last frames and
  // heartbeat), so the first period does not see them as missing.
  void SetInitialDeviceState(const DeviceState& state) { device_state_ = state; }

  const DeviceState& device_state() const { return device_state_; }
  const CycleOutput& output() const { return output_; }
  const SafetyMonitor& safety() const { return safety_; }
  const CycleOptions& options() const { return options_; }

 private:
  HapticDevice* device_;
  BaseResponseSource* source_;
  CycleOptions options_;
  SafetyMonitor safety_;
  DeviceState device_state_{};
  ControllerState controller_{};
  CycleOutput output_{};
  std::uint64_t reported_hard_{0};
  std::uint64_t reported_transient_{0};
  std::uint64_t seen_recoveries_{0};
  bool enable_pending_{false};
  double last_enable_s_{kNever_s};
  std::optional<double> start_s_;  // the first period: log times are relative to it
};

}  // namespace ves::haptics
