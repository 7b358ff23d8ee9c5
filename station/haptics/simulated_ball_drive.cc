#include "station/haptics/simulated_ball_drive.h"

#include <poll.h>

#include <cmath>
#include <stdexcept>
#include <string>

namespace ves::haptics {

SimulatedBallDrive::SimulatedBallDrive(CanBus bus, SimulatedBallDriveOptions options)
    : bus_(std::move(bus)), options_(options), rng_(options.seed) {
  if (!(options_.period_s > 0.0)) {
    throw std::invalid_argument("SimulatedBallDrive period_s must be > 0, got " +
                                std::to_string(options_.period_s));
  }
  if (options_.substeps < 1) {
    throw std::invalid_argument("SimulatedBallDrive substeps must be >= 1, got " +
                                std::to_string(options_.substeps));
  }
  CalcHandLoad(options_.hand, plant_, 0.0, &plant_.hand_force_N, &plant_.hand_torque_Nm);
}

void SimulatedBallDrive::Service(double now_s) {
  if (!booted_) {
    booted_ = true;
    last_host_heartbeat_s_ = now_s;
    nmt_state_ = NmtState::kPreOperational;
    Send(EncodeHeartbeat({kDeviceNodeId, NmtState::kBootUp}));
    last_heartbeat_sent_s_ = now_s;
  }
  can_frame frame{};
  for (;;) {
    const CanBus::ReadResult result = bus_.Read(&frame, 0);
    if (result == CanBus::ReadResult::kFrame) {
      Handle(now_s, frame);
    } else if (result == CanBus::ReadResult::kMalformed) {
      ++malformed_frames_;
    } else {
      break;
    }
  }
  // Device-side safety: no station heartbeat -> motors off, EMCY.
  if (nmt_state_ == NmtState::kOperational && !host_heartbeat_lost_ &&
      now_s - last_host_heartbeat_s_ > options_.host_heartbeat_timeout_s) {
    host_heartbeat_lost_ = true;
    latched_ = {};
    Emcy emcy;
    emcy.node_id = kDeviceNodeId;
    emcy.code = EmcyCode::kHeartbeatLost;
    emcy.error_register = 0x11;  // generic + communication
    Send(EncodeEmcy(emcy));
  }
  if (!faults_.mute_heartbeat && now_s - last_heartbeat_sent_s_ >= options_.heartbeat_period_s) {
    Send(EncodeHeartbeat({kDeviceNodeId, nmt_state_}));
    last_heartbeat_sent_s_ = now_s;
  }
}

void SimulatedBallDrive::ServiceWait(int timeout_ms, double now_s) {
  pollfd waiter{bus_.fd(), POLLIN, 0};
  poll(&waiter, 1, timeout_ms);
  Service(now_s);
}

void SimulatedBallDrive::Handle(double now_s, const can_frame& frame) {
  switch (ClassifyFrame(frame)) {
    case FrameKind::kNmt: {
      const auto nmt = DecodeNmtFrame(frame);
      if (!nmt || (nmt->node_id != 0 && nmt->node_id != kDeviceNodeId)) break;
      switch (nmt->command) {
        case NmtCommandSpecifier::kStart:
          nmt_state_ = NmtState::kOperational;
          host_heartbeat_lost_ = false;
          last_host_heartbeat_s_ = now_s;
          break;
        case NmtCommandSpecifier::kStop:
          nmt_state_ = NmtState::kStopped;
          latched_ = {};
          break;
        case NmtCommandSpecifier::kEnterPreOperational:
        case NmtCommandSpecifier::kResetNode:
          nmt_state_ = NmtState::kPreOperational;
          latched_ = {};
          break;
      }
      break;
    }
    case FrameKind::kMotorPdo:
      if (nmt_state_ == NmtState::kOperational && !host_heartbeat_lost_) {
        latched_ = *DecodeMotorFrame(frame);
      }
      break;
    case FrameKind::kSync:
      OnSync(*DecodeSyncFrame(frame));
      break;
    case FrameKind::kHeartbeat: {
      const auto heartbeat = DecodeHeartbeatFrame(frame);
      if (heartbeat && heartbeat->node_id == kHostNodeId) {
        ++host_heartbeats_;
        last_host_heartbeat_s_ = now_s;
      }
      break;
    }
    case FrameKind::kEmcy:
      received_emcy_.push_back(*DecodeEmcyFrame(frame));
      break;
    case FrameKind::kBadLength:
    case FrameKind::kUnknownId:
      ++malformed_frames_;
      break;
    case FrameKind::kEncoderPdo:
    case FrameKind::kSensorPdo:
    case FrameKind::kBusError:
      break;
  }
}

void SimulatedBallDrive::OnSync(std::uint8_t counter) {
  ++syncs_;
  // The plant runs whatever the NMT state; only operational drives the motors.
  applied_ = nmt_state_ == NmtState::kOperational ? latched_ : MotorVoltages{};
  StepBallDrive(options_.params, options_.hand, applied_, options_.period_s, options_.substeps,
                &plant_);
  if (nmt_state_ != NmtState::kOperational) return;  // PDOs only when operational
  if (!faults_.mute_encoder_pdo) {
    Send(EncodeEncoderPdo(
        {MetersToInsertionCounts(plant_.insertion_m), RadiansToRollCounts(plant_.roll_motor_rad)}));
  }
  if (!faults_.mute_sensor_pdo) {
    SensorSample sample;
    sample.axial_force_N = plant_.hand_force_N + options_.force_noise_N * unit_noise_(rng_);
    sample.axial_torque_Nm = plant_.hand_torque_Nm + options_.torque_noise_Nm * unit_noise_(rng_);
    sample.sync_counter = counter;
    sample.status = kStatusOperational | (host_heartbeat_lost_ ? 0 : kStatusMotorsEnabled);
    Send(EncodeSensorPdo(sample));
  }
}

void SimulatedBallDrive::SendBusError(const BusError& error) { Send(EncodeBusError(error)); }

void SimulatedBallDrive::SendRawFrame(const can_frame& frame) { Send(frame); }

void SimulatedBallDrive::Send(const can_frame& frame) { bus_.Write(frame); }

}  // namespace ves::haptics
