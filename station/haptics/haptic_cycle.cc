#include "station/haptics/haptic_cycle.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace ves::haptics {
namespace {

bool AllFinite(const DeviceState& s) {
  return std::isfinite(s.insertion_m) && std::isfinite(s.insertion_velocity_m_per_s) &&
         std::isfinite(s.roll_rad) && std::isfinite(s.roll_velocity_rad_per_s) &&
         std::isfinite(s.force_N) && std::isfinite(s.torque_Nm);
}

double ClampFinite(double value, double limit, bool* non_finite) {
  if (!std::isfinite(value)) {
    *non_finite = true;
    return 0.0;
  }
  return std::clamp(value, -limit, limit);
}

}  // namespace

MotorCommand ClampCommand(const MotorCommand& command, const OutputLimits& limits,
                          bool* non_finite) {
  MotorCommand clamped = command;
  clamped.thrust_force_N = ClampFinite(command.thrust_force_N, limits.max_force_N, non_finite);
  clamped.roll_torque_Nm = ClampFinite(command.roll_torque_Nm, limits.max_torque_Nm, non_finite);
  return clamped;
}

HapticCycle::HapticCycle(HapticDevice* device, BaseResponseSource* source, CycleOptions options)
    : device_(device), source_(source), options_(options), safety_(options.safety) {
  if (device_ == nullptr) throw std::invalid_argument("HapticCycle needs a device");
  if (options_.control.mode == ControlMode::kCoupled && source_ == nullptr) {
    throw std::invalid_argument("HapticCycle coupled mode needs a BaseResponseSource");
  }
  if (!(options_.period_s > 0.0)) {
    throw std::invalid_argument("HapticCycle period_s must be > 0, got " +
                                std::to_string(options_.period_s));
  }
  if (options_.control.spring_stiffness_N_per_m <= 0.0 ||
      options_.control.spring_stiffness_Nm_per_rad <= 0.0) {
    throw std::invalid_argument(
        "HapticCycle spring stiffness must be > 0, got " +
        std::to_string(options_.control.spring_stiffness_N_per_m) + " N/m and " +
        std::to_string(options_.control.spring_stiffness_Nm_per_rad) + " N·m/rad");
  }
}

const CycleOutput& HapticCycle::Run(double now_s) {
  if (!start_s_) start_s_ = now_s;
  device_->Read(now_s, &device_state_);
  // The one check of the device's readings, where they enter the station: a
  // non-finite one (a sensor's NaN) never reaches the model or a controller
  // and trips the safe state (kNonFinite) in this period.
  const bool readings_finite = AllFinite(device_state_);
  const double dt_s = options_.period_s;
  const bool coupled = options_.control.mode == ControlMode::kCoupled;
  std::optional<std::uint64_t> model_count;
  if (coupled && readings_finite) {
    output_.base = source_->Update(device_state_.insertion_m, device_state_.roll_rad, dt_s);
    model_count = output_.base.update_count;
  }
  // The model's response is checked where it enters the cycle.
  const bool non_finite =
      !readings_finite || (coupled && !(std::isfinite(output_.base.thrust_force_N) &&
                                        std::isfinite(output_.base.roll_torque_Nm)));
  safety_.Check(device_state_, now_s, non_finite, model_count);
  if (safety_.recoveries() != seen_recoveries_) {
    // A transient fault cleared: track from where the scope is now, not
    // from where the targets were when the output stopped.
    seen_recoveries_ = safety_.recoveries();
    controller_ = CalcInitialControllerState(device_state_);
    spdlog::warn("haptics: bus healthy again at t={:.3f} s; output fades in over {:.1f} s",
                 now_s - *start_s_, safety_.limits().fade_in_s);
  }

  MotorCommand command{};  // powered = false: 0 V
  if (!safety_.safe()) {
    switch (options_.control.mode) {
      case ControlMode::kFree:
        command = CalcFreeCommand(device_state_, options_.control, dt_s, &controller_);
        break;
      case ControlMode::kSpring:
        command = CalcSpringCommand(device_state_, options_.control);
        break;
      case ControlMode::kCoupled:
        command =
            CalcCoupledCommand(device_state_, output_.base, options_.control, dt_s, &controller_);
        break;
    }
    // The one clamp of the motor command (OutputLimits, the one setting):
    // what the device is written is finite and within the limits.
    bool bad_command = false;
    command = ClampCommand(command, options_.limits, &bad_command);
    if (bad_command) {
      safety_.Trip(SafetyFault::kNonFinite);
      command = MotorCommand{};
    } else {
      command.thrust_force_N *= safety_.output_scale();
      command.roll_torque_Nm *= safety_.output_scale();
    }
  }
  output_.fault = safety_.fault();
  output_.output_scale = safety_.output_scale();
  output_.command = command;
  const double t_s = now_s - *start_s_;
  if (safety_.hard_faults() != reported_hard_) {
    // Entering the safe state: EMCY on the bus and one log line.
    reported_hard_ = safety_.hard_faults();
    device_->SendEmergency(now_s, ToEmcyCode(safety_.fault()));
    spdlog::error("haptics: safe state at t={:.3f} s: {} (zero output until re-arm)", t_s,
                  ToString(safety_.fault()));
  } else if (safety_.transient_faults() != reported_transient_) {
    reported_transient_ = safety_.transient_faults();
    device_->SendEmergency(now_s, ToEmcyCode(safety_.fault()));
    spdlog::warn("haptics: transient fault at t={:.3f} s: {} (output held at zero until the bus "
                 "is healthy)",
                 t_s, ToString(safety_.fault()));
  }
  if (IsTransient(safety_.fault()) &&
      (device_state_.device_missed_heartbeat || !device_state_.motors_enabled ||
       device_state_.device_nmt_state != NmtState::kOperational) &&
      now_s - last_enable_s_ >= kEnableRetry_s) {
    enable_pending_ = true;  // a device that cut its motors waits for NMT start
    device_state_.device_missed_heartbeat = false;
  }
  if (enable_pending_) {
    device_->Enable(now_s);  // before this period's RPDO and SYNC
    enable_pending_ = false;
    last_enable_s_ = now_s;
  }
  device_->Write(now_s, command);
  return output_;
}

void HapticCycle::Rearm() {
  device_->ClearFaultFlags(&device_state_);
  controller_ = CalcInitialControllerState(device_state_);
  safety_.Rearm();
  enable_pending_ = true;
}

}  // namespace ves::haptics
