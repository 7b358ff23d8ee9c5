#pragma once

// SimulatedBallDrive: the VES-IV as a CAN node on the far end of a CanBus.
// It behaves as the device firmware would: boots pre-operational and sends a
// boot-up heartbeat, enters operational on NMT start, applies the latest RPDO1
// voltages at each SYNC, advances the plant one SYNC period, and answers with
// TPDO1 (encoder counts) and TPDO2 (sensor, with seeded noise). It watches
// the station's heartbeat and cuts the motors (and sends EMCY) when it stops.
// Faults can be injected for the safety tests.
#include <cstdint>
#include <random>
#include <vector>

#include "station/haptics/ball_drive_plant.h"
#include "station/haptics/can_bus.h"
#include "station/haptics/protocol.h"

namespace ves::haptics {

struct SimulatedBallDriveOptions {
  BallDriveParams params{};
  HandProfile hand{};
  double period_s{0.001};  // plant time per SYNC
  int substeps{20};
  double force_noise_N{0.005};  // sensor noise, standard deviation
  double torque_noise_Nm{5e-5};
  std::uint64_t seed{1};
  double heartbeat_period_s{0.010};
  double host_heartbeat_timeout_s{0.025};
};

struct SimulatedFaults {
  bool mute_sensor_pdo{false};  // force sensor goes silent
  bool mute_encoder_pdo{false};
  bool mute_heartbeat{false};
  bool operator==(const SimulatedFaults&) const = default;
};

class SimulatedBallDrive {
 public:
  SimulatedBallDrive(CanBus bus, SimulatedBallDriveOptions options);

  // Handles every pending frame, then sends a heartbeat when due. Non-blocking.
  void Service(double now_s);
  // Waits up to timeout_ms for a frame, then Service(now_s()). For a thread.
  void ServiceWait(int timeout_ms, double now_s);

  void set_faults(const SimulatedFaults& faults) { faults_ = faults; }
  void set_hand(const HandProfile& hand) { options_.hand = hand; }
  // Frames the device (or its controller) puts on the bus for fault injection.
  void SendBusError(const BusError& error);
  void SendRawFrame(const can_frame& frame);

  const PlantState& plant() const { return plant_; }
  int bus_fd() const { return bus_.fd(); }
  NmtState nmt_state() const { return nmt_state_; }
  MotorVoltages applied_voltages() const { return applied_; }
  const std::vector<Emcy>& received_emcy() const { return received_emcy_; }
  std::uint64_t syncs() const { return syncs_; }
  std::uint64_t malformed_frames() const { return malformed_frames_; }
  std::uint64_t host_heartbeats() const { return host_heartbeats_; }
  bool host_heartbeat_lost() const { return host_heartbeat_lost_; }

 private:
  void Handle(double now_s, const can_frame& frame);
  void OnSync(std::uint8_t counter);
  void Send(const can_frame& frame);

  CanBus bus_;
  SimulatedBallDriveOptions options_;
  SimulatedFaults faults_{};
  PlantState plant_{};
  NmtState nmt_state_{NmtState::kBootUp};
  MotorVoltages latched_{};  // last RPDO1 received
  MotorVoltages applied_{};  // what the pairs got over the last SYNC period
  std::mt19937_64 rng_;
  std::normal_distribution<double> unit_noise_{0.0, 1.0};
  std::vector<Emcy> received_emcy_;
  std::uint64_t syncs_{0};
  std::uint64_t malformed_frames_{0};
  std::uint64_t host_heartbeats_{0};
  double last_heartbeat_sent_s_{-1e300};
  double last_host_heartbeat_s_{-1e300};
  bool host_heartbeat_lost_{false};
  bool booted_{false};
};

}  // namespace ves::haptics
