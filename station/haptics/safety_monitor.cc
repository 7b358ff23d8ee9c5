#include "station/haptics/safety_monitor.h"

#include <algorithm>
#include <stdexcept>
#include <string>

namespace ves::haptics {

const char* ToString(SafetyFault fault) {
  switch (fault) {
    case SafetyFault::kNone:
      return "none";
    case SafetyFault::kNotArmed:
      return "not-armed";
    case SafetyFault::kSensorTimeout:
      return "sensor-timeout";
    case SafetyFault::kHeartbeatLost:
      return "heartbeat-lost";
    case SafetyFault::kDeviceMissedHeartbeat:
      return "device-missed-heartbeat";
    case SafetyFault::kCommunicationLost:
      return "communication-lost";
    case SafetyFault::kBusOff:
      return "bus-off";
    case SafetyFault::kErrorPassive:
      return "error-passive";
    case SafetyFault::kLinkDown:
      return "link-down";
    case SafetyFault::kNonFinite:
      return "non-finite";
    case SafetyFault::kModelStalled:
      return "model-stalled";
    case SafetyFault::kDeviceEmergency:
      return "device-emergency";
  }
  return "unknown";
}

EmcyCode ToEmcyCode(SafetyFault fault) {
  switch (fault) {
    case SafetyFault::kNone:
    case SafetyFault::kNotArmed:
      return EmcyCode::kNoError;
    case SafetyFault::kSensorTimeout:
      return EmcyCode::kSensorTimeout;
    case SafetyFault::kHeartbeatLost:
      return EmcyCode::kHeartbeatLost;
    case SafetyFault::kCommunicationLost:
      return EmcyCode::kSensorTimeout;
    case SafetyFault::kDeviceMissedHeartbeat:
    case SafetyFault::kBusOff:
    case SafetyFault::kLinkDown:
      return EmcyCode::kCanBusOff;
    case SafetyFault::kErrorPassive:
      return EmcyCode::kCanErrorPassive;
    case SafetyFault::kNonFinite:
      return EmcyCode::kSoftwareNonFinite;
    case SafetyFault::kModelStalled:
      return EmcyCode::kModelStalled;
    case SafetyFault::kDeviceEmergency:
      return EmcyCode::kDeviceReported;
  }
  return EmcyCode::kNoError;
}

bool IsTransient(SafetyFault fault) {
  return fault == SafetyFault::kSensorTimeout || fault == SafetyFault::kHeartbeatLost ||
         fault == SafetyFault::kDeviceMissedHeartbeat;
}

SafetyMonitor::SafetyMonitor(SafetyLimits limits) : limits_(limits) {
  const auto require_positive = [](double value, const char* name) {
    if (!(value > 0.0)) {
      throw std::invalid_argument(std::string("SafetyLimits ") + name + " must be > 0, got " +
                                  std::to_string(value));
    }
  };
  require_positive(limits_.sensor_timeout_s, "sensor_timeout_s");
  require_positive(limits_.heartbeat_timeout_s, "heartbeat_timeout_s");
  require_positive(limits_.stall_gap_s, "stall_gap_s");
  require_positive(limits_.fade_in_s, "fade_in_s");
  if (limits_.model_stall_periods < 1) {
    throw std::invalid_argument("SafetyLimits model_stall_periods must be >= 1, got " +
                                std::to_string(limits_.model_stall_periods));
  }
  if (!(limits_.hard_after_s > limits_.healthy_before_fade_s &&
        limits_.healthy_before_fade_s >= 0.0 && limits_.max_transient_s >= limits_.hard_after_s)) {
    throw std::invalid_argument(
        "SafetyLimits needs 0 <= healthy_before_fade_s < hard_after_s <= max_transient_s, got " +
        std::to_string(limits_.healthy_before_fade_s) + ", " +
        std::to_string(limits_.hard_after_s) + " and " + std::to_string(limits_.max_transient_s));
  }
}

void SafetyMonitor::Silence::Update(double stamp_s, double dt_s) {
  if (stamp_s != last_seen_s) {
    last_seen_s = stamp_s;
    silent_s = 0.0;
  } else {
    silent_s += dt_s;
  }
}

SafetyFault SafetyMonitor::EvaluateHard(const DeviceState& device, bool non_finite) const {
  if (non_finite) return SafetyFault::kNonFinite;
  if (device.link_down) return SafetyFault::kLinkDown;
  if (device.bus_off) return SafetyFault::kBusOff;
  if (device.error_passive) return SafetyFault::kErrorPassive;
  if (device.device_emergency) return SafetyFault::kDeviceEmergency;
  if (stale_model_periods_ >= limits_.model_stall_periods) return SafetyFault::kModelStalled;
  return SafetyFault::kNone;
}

// Time sums of 1 ms steps are not exact: a silence of 5 periods is 5 ms.
constexpr double kTimeSlack_s = 1e-9;

SafetyFault SafetyMonitor::EvaluateTransient(const DeviceState& device) const {
  if (device.device_missed_heartbeat) return SafetyFault::kDeviceMissedHeartbeat;
  if (std::max(sensor_.silent_s, encoder_.silent_s) >= limits_.sensor_timeout_s - kTimeSlack_s) {
    return SafetyFault::kSensorTimeout;
  }
  if (heartbeat_.silent_s >= limits_.heartbeat_timeout_s - kTimeSlack_s) {
    return SafetyFault::kHeartbeatLost;
  }
  return SafetyFault::kNone;
}

bool SafetyMonitor::BusHealthy(const DeviceState& device) const {
  return std::max(sensor_.silent_s, encoder_.silent_s) <= limits_.stall_gap_s + kTimeSlack_s &&
         heartbeat_.silent_s < limits_.heartbeat_timeout_s &&
         device.device_nmt_state == NmtState::kOperational && device.motors_enabled &&
         !device.device_missed_heartbeat;
}

void SafetyMonitor::Latch(SafetyFault fault) {
  fault_ = fault;
  ++hard_faults_;
  episode_s_ = 0.0;
  healthy_s_ = 0.0;
  unhealthy_s_ = 0.0;
}

SafetyFault SafetyMonitor::Check(const DeviceState& device, double now_s, bool non_finite,
                                 std::optional<std::uint64_t> model_update_count) {
  double dt_s = 0.0;
  if (previous_now_s_) {
    dt_s = std::max(0.0, now_s - *previous_now_s_);
    if (dt_s > limits_.stall_gap_s) {
      ++stalls_;
      dt_s = limits_.stall_gap_s;  // the station stalled, not the bus
    }
  }
  previous_now_s_ = now_s;
  sensor_.Update(device.last_sensor_time_s, dt_s);
  encoder_.Update(device.last_encoder_time_s, dt_s);
  heartbeat_.Update(device.last_heartbeat_time_s, dt_s);
  if (model_update_count) {
    if (last_model_count_ && *last_model_count_ == *model_update_count) {
      ++stale_model_periods_;
    } else {
      stale_model_periods_ = 0;
    }
    last_model_count_ = model_update_count;
  }

  if (fault_ != SafetyFault::kNone && !IsTransient(fault_)) return fault_;  // until Rearm()
  const SafetyFault hard = EvaluateHard(device, non_finite);
  if (hard != SafetyFault::kNone) {
    Latch(hard);
    return fault_;
  }
  const SafetyFault transient = EvaluateTransient(device);
  if (fault_ == SafetyFault::kNone) {
    if (transient != SafetyFault::kNone) {
      fault_ = transient;
      ++transient_faults_;
      episode_s_ = 0.0;
      healthy_s_ = 0.0;
      unhealthy_s_ = 0.0;
      output_scale_ = 0.0;
    } else {
      output_scale_ = std::min(1.0, output_scale_ + dt_s / limits_.fade_in_s);
    }
    return fault_;
  }
  // In a transient fault: wait for the bus to be healthy for a while. A gap
  // of hard_after_s without a healthy period, or no recovery within
  // max_transient_s, is no longer transient.
  episode_s_ += dt_s;
  if (transient == SafetyFault::kNone && BusHealthy(device)) {
    healthy_s_ += dt_s;
    unhealthy_s_ = 0.0;
    if (healthy_s_ >= limits_.healthy_before_fade_s - kTimeSlack_s) {
      fault_ = SafetyFault::kNone;
      ++recoveries_;
      episode_s_ = 0.0;
      output_scale_ = 0.0;  // rises from the next period on
      return fault_;
    }
  } else {
    healthy_s_ = 0.0;
    unhealthy_s_ += dt_s;
  }
  if (unhealthy_s_ >= limits_.hard_after_s - kTimeSlack_s ||
      episode_s_ >= limits_.max_transient_s - kTimeSlack_s) {
    Latch(SafetyFault::kCommunicationLost);
  }
  return fault_;
}

void SafetyMonitor::Trip(SafetyFault fault) {
  if (fault_ == SafetyFault::kNone || IsTransient(fault_)) Latch(fault);
}

void SafetyMonitor::Rearm() {
  fault_ = SafetyFault::kNone;
  output_scale_ = 1.0;
  episode_s_ = 0.0;
  healthy_s_ = 0.0;
  stale_model_periods_ = 0;
  last_model_count_.reset();
}

}  // namespace ves::haptics
