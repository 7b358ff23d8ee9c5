#pragma once

// The watchdog of the 1 kHz loop (docs/can-protocol.md, "Safety"). Each
// period it checks the rules below; a fault takes the output to zero (0 V on
// both pairs) in that same period. Faults come in two kinds:
//   hard — need an explicit Rearm() by hand:
//     - a bus-off or error-passive error frame, or the transport failing
//     - a NaN or Inf in the measurements, the model response or the command
//     - no model update (coupled mode) for model_stall_periods periods
//     - an EMCY from the device other than "heartbeat lost"
//     - a communication gap of hard_after_s of bus time (communication-lost:
//       long silence, a device that will not restart), or a transient fault
//       that has not cleared within max_transient_s (a bus that keeps
//       dropping out)
//   transient — a communication gap; cleared without a re-arm:
//     - no encoder or sensor frame for sensor_timeout_s of bus time
//     - no device heartbeat for heartbeat_timeout_s of bus time
//     - the device's EMCY "heartbeat lost": it cut its motors because the
//       station's heartbeat stopped (the station itself was stalled)
//     The output stays at zero until the bus has been healthy (fresh PDOs,
//     heartbeat, device operational with its motors enabled) for
//     healthy_before_fade_s, then fades back in over fade_in_s.
//
// Silence is judged by what the bus delivered while the loop ran, not by the
// wall clock: each period adds the time since the previous one, but at most
// stall_gap_s. A stall of the station's own process or loop thread (the
// device was not asked: no SYNC went out) therefore adds one short gap, not
// its length, while a device that stops answering a loop that runs on time
// still trips after sensor_timeout_s.
#include <cstdint>
#include <optional>

#include "station/haptics/device.h"
#include "station/haptics/protocol.h"

namespace ves::haptics {

struct SafetyLimits {
  double sensor_timeout_s{0.005};
  double heartbeat_timeout_s{0.025};
  int model_stall_periods{2};
  double hard_after_s{0.100};
  double max_transient_s{1.0};
  double stall_gap_s{0.002};
  double healthy_before_fade_s{0.050};
  double fade_in_s{0.300};
  bool operator==(const SafetyLimits&) const = default;
};

enum class SafetyFault : std::uint8_t {
  kNone,
  kNotArmed,  // the state after start-up: safe until the first arm
  // transient
  kSensorTimeout,
  kHeartbeatLost,
  kDeviceMissedHeartbeat,  // the device lost the station's heartbeat and cut its motors
  // hard
  kCommunicationLost,  // a transient fault that did not clear within hard_after_s
  kBusOff,
  kErrorPassive,
  kLinkDown,
  kNonFinite,
  kModelStalled,
  kDeviceEmergency,  // the device reported another fault (EMCY) and cut its motors
};

const char* ToString(SafetyFault fault);
EmcyCode ToEmcyCode(SafetyFault fault);
// Transient faults clear by themselves; every other fault but kNone needs a re-arm.
bool IsTransient(SafetyFault fault);

class SafetyMonitor {
 public:
  explicit SafetyMonitor(SafetyLimits limits = {});

  // Applies the rules for this period. model_update_count is empty when no
  // model is in the loop. Returns the fault (kNone when the output may flow).
  SafetyFault Check(const DeviceState& device, double now_s, bool non_finite,
                    std::optional<std::uint64_t> model_update_count);
  // Latches the hard fault `fault` now (e.g. a NaN found in the command after Check()).
  void Trip(SafetyFault fault);
  // Clears any fault; full output at once. The rules run again in the next Check().
  void Rearm();

  bool safe() const { return fault_ != SafetyFault::kNone; }
  SafetyFault fault() const { return fault_; }
  // Share of the controller's command that goes out: 0 while safe, rising
  // to 1 over fade_in_s after a transient fault cleared.
  double output_scale() const { return safe() ? 0.0 : output_scale_; }
  std::uint64_t hard_faults() const { return hard_faults_; }
  std::uint64_t transient_faults() const { return transient_faults_; }
  std::uint64_t recoveries() const { return recoveries_; }
  // Periods whose gap to the previous one exceeded stall_gap_s (the station stalled).
  std::uint64_t stalls() const { return stalls_; }
  // Bus time the current transient fault has lasted (0 when none).
  double transient_elapsed_s() const { return episode_s_; }
  const SafetyLimits& limits() const { return limits_; }

 private:
  struct Silence {
    double last_seen_s{kNever_s};  // the DeviceState time stamp seen last
    double silent_s{0.0};          // bus time since it last changed
    void Update(double stamp_s, double dt_s);
  };

  SafetyFault EvaluateHard(const DeviceState& device, bool non_finite) const;
  SafetyFault EvaluateTransient(const DeviceState& device) const;
  bool BusHealthy(const DeviceState& device) const;
  void Latch(SafetyFault fault);

  SafetyLimits limits_;
  SafetyFault fault_{SafetyFault::kNotArmed};
  std::uint64_t hard_faults_{0};
  std::uint64_t transient_faults_{0};
  std::uint64_t recoveries_{0};
  std::uint64_t stalls_{0};
  std::optional<double> previous_now_s_;
  Silence sensor_;
  Silence encoder_;
  Silence heartbeat_;
  double episode_s_{0.0};    // bus time in the current transient fault
  double healthy_s_{0.0};    // bus time the bus has been healthy since it last was not
  double unhealthy_s_{0.0};  // bus time it has not been healthy since it last was
  double output_scale_{1.0};
  std::optional<std::uint64_t> last_model_count_;
  int stale_model_periods_{0};
};

}  // namespace ves::haptics
