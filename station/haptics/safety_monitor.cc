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

SafetyMonitor::SafetyMonitor(SafetyLimits limits) : limits_(limits) {
  if (!(limits_.sensor_timeout_s > 0.0)) {
    throw std::invalid_argument("SafetyLimits sensor_timeout_s must be > 0, got " +
                                std::to_string(limits_.sensor_timeout_s));
  }
  if (!(limits_.heartbeat_timeout_s > 0.0)) {
    throw std::invalid_argument("SafetyLimits heartbeat_timeout_s must be > 0, got " +
                                std::to_string(limits_.heartbeat_timeout_s));
  }
  if (limits_.model_stall_periods < 1) {
    throw std::invalid_argument("SafetyLimits model_stall_periods must be >= 1, got " +
                                std::to_string(limits_.model_stall_periods));
  }
}

SafetyFault SafetyMonitor::Evaluate(const DeviceState& device, double now_s, bool non_finite,
                                    std::optional<std::uint64_t> model_update_count) {
  if (model_update_count) {
    if (last_model_count_ && *last_model_count_ == *model_update_count) {
      ++stale_model_periods_;
    } else {
      stale_model_periods_ = 0;
    }
    last_model_count_ = model_update_count;
  }
  if (non_finite) return SafetyFault::kNonFinite;
  if (device.link_down) return SafetyFault::kLinkDown;
  if (device.bus_off) return SafetyFault::kBusOff;
  if (device.error_passive) return SafetyFault::kErrorPassive;
  if (device.device_emergency) return SafetyFault::kDeviceEmergency;
  const double oldest_sample_s = std::min(device.last_sensor_time_s, device.last_encoder_time_s);
  if (now_s - oldest_sample_s > limits_.sensor_timeout_s) return SafetyFault::kSensorTimeout;
  if (now_s - device.last_heartbeat_time_s > limits_.heartbeat_timeout_s) {
    return SafetyFault::kHeartbeatLost;
  }
  if (stale_model_periods_ >= limits_.model_stall_periods) return SafetyFault::kModelStalled;
  return SafetyFault::kNone;
}

SafetyFault SafetyMonitor::Check(const DeviceState& device, double now_s, bool non_finite,
                                 std::optional<std::uint64_t> model_update_count) {
  const SafetyFault found = Evaluate(device, now_s, non_finite, model_update_count);
  if (fault_ == SafetyFault::kNone && found != SafetyFault::kNone) Trip(found);
  return fault_;
}

void SafetyMonitor::Trip(SafetyFault fault) {
  if (fault_ == SafetyFault::kNone) {
    fault_ = fault;
    ++trips_;
  }
}

void SafetyMonitor::Rearm() {
  fault_ = SafetyFault::kNone;
  stale_model_periods_ = 0;
  last_model_count_.reset();
}

}  // namespace ves::haptics
