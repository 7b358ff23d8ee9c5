#pragma once

// Ves4Device: the station's driver for the VES-IV ball drive over CAN
// (docs/can-protocol.md). Each Write() sends RPDO1 (pair voltages) then SYNC;
// the device answers each SYNC with TPDO1 (encoders) and TPDO2 (force sensor),
// which the next Read() picks up. Counts become SI here and nowhere else.
#include <cstdint>

#include "station/haptics/ball_drive_params.h"
#include "station/haptics/can_bus.h"
#include "station/haptics/candump_log.h"
#include "station/haptics/device.h"

namespace ves::haptics {

struct Ves4DeviceOptions {
  double period_s{0.001};            // SYNC period
  double heartbeat_period_s{0.010};  // our heartbeat to the device
  double velocity_cutoff_Hz{100.0};  // low-pass on encoder differences
  int max_frames_per_read{64};       // bounds the time one Read() may take
};

class Ves4Device final : public HapticDevice {
 public:
  Ves4Device(CanBus bus, BallDriveParams params, Ves4DeviceOptions options = {});

  void Read(double now_s, DeviceState* state) override;
  void Write(double now_s, const MotorCommand& command) override;
  void SendEmergency(double now_s, EmcyCode code) override;
  void Enable(double now_s) override { SendNmt(now_s, NmtCommandSpecifier::kStart); }
  void ClearFaultFlags(DeviceState* state) override;
  DeviceCounters counters() const override { return counters_; }

  // NMT start / stop of the device node.
  void SendNmt(double now_s, NmtCommandSpecifier command);
  // Every frame sent or received goes to the recorder too (may be null).
  void SetRecorder(CanFrameRecorder* recorder) { recorder_ = recorder; }

  // The voltages of the last RPDO sent (what the pairs get).
  MotorVoltages last_voltages() const { return last_voltages_; }
  const BallDriveParams& params() const { return params_; }
  CanBus& bus() { return bus_; }

 private:
  void Send(double now_s, const can_frame& frame);
  void Handle(double now_s, const can_frame& frame, DeviceState* state);

  CanBus bus_;
  BallDriveParams params_;
  Ves4DeviceOptions options_;
  CanFrameRecorder* recorder_{nullptr};
  DeviceCounters counters_{};
  MotorVoltages last_voltages_{};
  std::uint8_t sync_counter_{0};
  std::uint8_t last_sensor_counter_{0};
  bool encoder_since_sensor_{false};
  bool have_encoder_{false};
  double last_heartbeat_sent_s_{kNever_s};
  double velocity_alpha_{1.0};
  // Unfiltered previous positions for the velocity estimate.
  double previous_insertion_m_{0.0};
  double previous_roll_rad_{0.0};
  double insertion_velocity_m_per_s_{0.0};
  double roll_velocity_rad_per_s_{0.0};
};

}  // namespace ves::haptics
