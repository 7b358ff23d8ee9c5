#pragma once

// The watchdog of the 1 kHz loop. Each period it checks the rules below; the
// first that fails latches a fault, and the loop then commands zero output
// (0 V on both pairs) until an explicit Rearm(). Nothing else leaves the
// safe state: a fault that goes away by itself leaves the output at zero.
//   - no encoder or sensor frame for sensor_timeout_s (5 ms)
//   - no device heartbeat for heartbeat_timeout_s
//   - a bus-off or error-passive error frame, or the transport failing
//   - a NaN or Inf in the measurements, the model response or the command
//   - no model update (coupled mode) for model_stall_periods (2) periods
//   - an EMCY from the device (it has cut its own motors)
#include <cstdint>
#include <optional>

#include "station/haptics/device.h"
#include "station/haptics/protocol.h"

namespace ves::haptics {

struct SafetyLimits {
  double sensor_timeout_s{0.005};
  double heartbeat_timeout_s{0.025};
  int model_stall_periods{2};
  bool operator==(const SafetyLimits&) const = default;
};

enum class SafetyFault : std::uint8_t {
  kNone,
  kNotArmed,  // the state after start-up: safe until the first arm
  kSensorTimeout,
  kHeartbeatLost,
  kBusOff,
  kErrorPassive,
  kLinkDown,
  kNonFinite,
  kModelStalled,
  kDeviceEmergency,  // the device reported a fault (EMCY) and cut its motors
};

const char* ToString(SafetyFault fault);
EmcyCode ToEmcyCode(SafetyFault fault);

class SafetyMonitor {
 public:
  explicit SafetyMonitor(SafetyLimits limits = {});

  // Applies the rules for this period. model_update_count is empty when no
  // model is in the loop. Returns the latched fault (kNone when armed).
  SafetyFault Check(const DeviceState& device, double now_s, bool non_finite,
                    std::optional<std::uint64_t> model_update_count);
  // Latches `fault` now (e.g. a NaN found in the command after Check()).
  void Trip(SafetyFault fault);
  // Clears the latch. The rules run again in the next Check().
  void Rearm();

  bool safe() const { return fault_ != SafetyFault::kNone; }
  SafetyFault fault() const { return fault_; }
  std::uint64_t trips() const { return trips_; }
  const SafetyLimits& limits() const { return limits_; }

 private:
  SafetyFault Evaluate(const DeviceState& device, double now_s, bool non_finite,
                       std::optional<std::uint64_t> model_update_count);

  SafetyLimits limits_;
  SafetyFault fault_{SafetyFault::kNotArmed};
  std::uint64_t trips_{0};
  std::optional<std::uint64_t> last_model_count_;
  int stale_model_periods_{0};
};

}  // namespace ves::haptics
