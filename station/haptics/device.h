#pragma once

// The haptic device as the 1 kHz loop sees it (ros2_control style read/write):
// Read() gathers what arrived since the last period, Write() sends this
// period's command. Neither blocks, throws or allocates. The real driver
// (Ves4Device over a CanBus) is the one implementation; the simulated device
// sits on the other end of the bus, so the same driver code runs everywhere.
#include <cstdint>
#include <limits>

#include "station/haptics/protocol.h"

namespace ves::haptics {

inline constexpr double kNever_s = -std::numeric_limits<double>::infinity();

struct DeviceState {
  double insertion_m{0.0};
  double insertion_velocity_m_per_s{0.0};
  double roll_rad{0.0};
  double roll_velocity_rad_per_s{0.0};
  double force_N{0.0};    // axial force the hand applies (sensor), + = pushing in
  double torque_Nm{0.0};  // torque about the scope axis the hand applies
  double last_encoder_time_s{kNever_s};
  double last_sensor_time_s{kNever_s};
  double last_heartbeat_time_s{kNever_s};
  NmtState device_nmt_state{NmtState::kBootUp};
  bool bus_off{false};           // seen since the last re-arm (sticky)
  bool error_passive{false};     // seen since the last re-arm (sticky)
  bool link_down{false};         // the transport failed (closed / read error)
  bool device_emergency{false};  // the device sent an EMCY (sticky until re-arm)
  // The device sent EMCY "heartbeat lost": it cut its motors because the
  // station's heartbeat stopped (sticky until the station sends NMT start).
  bool device_missed_heartbeat{false};
  bool motors_enabled{false};  // TPDO2 status bit 1: the device drives its motors
  bool operator==(const DeviceState&) const = default;
};

// Output at the scope: thrust force and roll torque. `powered` false means
// the motor pairs get exactly 0 V (the safe state), whatever the values say.
struct MotorCommand {
  double thrust_force_N{0.0};
  double roll_torque_Nm{0.0};
  bool powered{false};
  bool operator==(const MotorCommand&) const = default;
};

struct DeviceCounters {
  std::uint64_t frames_received{0};
  std::uint64_t frames_sent{0};
  std::uint64_t send_failures{0};
  std::uint64_t lost_frames{0};       // PDOs that never arrived (SYNC counter gaps)
  std::uint64_t bus_errors{0};        // error frames of any class
  std::uint64_t malformed_frames{0};  // wrong length, unknown id, wrong record size
  std::uint64_t emcy_received{0};
  std::uint16_t last_emcy_code{0};
  bool operator==(const DeviceCounters&) const = default;
};

class HapticDevice {
 public:
  virtual ~HapticDevice() = default;
  // Drains everything that arrived; updates *state. Never blocks. The
  // readings are checked once, by HapticCycle::Run right after this call: a
  // non-finite one trips the safe state there and goes no further.
  virtual void Read(double now_s, DeviceState* state) = 0;
  // Sends the command for this period (and SYNC, heartbeat when due).
  // `command` is finite and within the loop's OutputLimits (haptic_cycle.h):
  // HapticCycle::Run clamps it, the one clamp on the way to the motors.
  virtual void Write(double now_s, const MotorCommand& command) = 0;
  // Announces a fault on the bus (EMCY from the station's node).
  virtual void SendEmergency(double now_s, EmcyCode code) = 0;
  // (Re-)enables the device's drive (NMT start); sent on every re-arm, since
  // a device that cut its motors itself waits for it.
  virtual void Enable(double now_s) = 0;
  // Clears the sticky bus flags in *state when the loop is re-armed.
  virtual void ClearFaultFlags(DeviceState* state) = 0;
  virtual DeviceCounters counters() const = 0;
};

}  // namespace ves::haptics
