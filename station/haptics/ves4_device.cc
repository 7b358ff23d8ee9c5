#include "station/haptics/ves4_device.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>

namespace ves::haptics {

Ves4Device::Ves4Device(CanBus bus, BallDriveParams params, Ves4DeviceOptions options)
    : bus_(std::move(bus)), params_(params), options_(options) {
  if (!(options_.period_s > 0.0)) {
    throw std::invalid_argument("Ves4Device period_s must be > 0, got " +
                                std::to_string(options_.period_s));
  }
  if (!(options_.velocity_cutoff_Hz > 0.0)) {
    throw std::invalid_argument("Ves4Device velocity_cutoff_Hz must be > 0, got " +
                                std::to_string(options_.velocity_cutoff_Hz));
  }
  // First-order low-pass: α = dt / (dt + 1/(2π f_c)).
  const double time_constant_s = 1.0 / (2.0 * std::numbers::pi * options_.velocity_cutoff_Hz);
  velocity_alpha_ = options_.period_s / (options_.period_s + time_constant_s);
}

void Ves4Device::Read(double now_s, DeviceState* state) {
  can_frame frame{};
  for (int i = 0; i < options_.max_frames_per_read; ++i) {
    const CanBus::ReadResult result = bus_.Read(&frame, 0);
    if (result == CanBus::ReadResult::kTimeout) break;
    if (result == CanBus::ReadResult::kMalformed) {
      ++counters_.malformed_frames;
      continue;
    }
    if (result != CanBus::ReadResult::kFrame) {
      state->link_down = true;
      break;
    }
    ++counters_.frames_received;
    if (recorder_ != nullptr) recorder_->Record(now_s, frame);
    Handle(now_s, frame, state);
  }
}

void Ves4Device::Handle(double now_s, const can_frame& frame, DeviceState* state) {
  switch (ClassifyFrame(frame)) {
    case FrameKind::kEncoderPdo: {
      const EncoderCounts counts = *DecodeEncoderFrame(frame);
      const double insertion_m = InsertionCountsToMeters(counts.insertion_counts);
      const double roll_rad = RollCountsToRadians(counts.roll_counts);
      if (have_encoder_) {
        const double raw_insertion_velocity =
            (insertion_m - previous_insertion_m_) / options_.period_s;
        const double raw_roll_velocity = (roll_rad - previous_roll_rad_) / options_.period_s;
        insertion_velocity_m_per_s_ +=
            velocity_alpha_ * (raw_insertion_velocity - insertion_velocity_m_per_s_);
        roll_velocity_rad_per_s_ +=
            velocity_alpha_ * (raw_roll_velocity - roll_velocity_rad_per_s_);
      }
      state->insertion_velocity_m_per_s = insertion_velocity_m_per_s_;
      state->roll_velocity_rad_per_s = roll_velocity_rad_per_s_;
      previous_insertion_m_ = insertion_m;
      previous_roll_rad_ = roll_rad;
      have_encoder_ = true;
      state->insertion_m = insertion_m;
      state->roll_rad = roll_rad;
      state->last_encoder_time_s = now_s;
      encoder_since_sensor_ = true;
      break;
    }
    case FrameKind::kSensorPdo: {
      const SensorSample sample = *DecodeSensorFrame(frame);
      state->force_N = sample.axial_force_N;
      state->torque_Nm = sample.axial_torque_Nm;
      state->motors_enabled = (sample.status & kStatusMotorsEnabled) != 0;
      state->last_sensor_time_s = now_s;
      if (last_sensor_counter_ != 0) {
        // TPDO2 echoes the SYNC counter: a gap is that many lost sensor PDOs.
        counters_.lost_frames += SyncCounterGap(last_sensor_counter_, sample.sync_counter);
      }
      // TPDO1 precedes TPDO2 for the same SYNC: a TPDO2 without it is a lost TPDO1.
      if (!encoder_since_sensor_ && last_sensor_counter_ != 0) ++counters_.lost_frames;
      last_sensor_counter_ = sample.sync_counter;
      encoder_since_sensor_ = false;
      break;
    }
    case FrameKind::kHeartbeat: {
      const auto heartbeat = DecodeHeartbeatFrame(frame);
      if (!heartbeat) {
        ++counters_.malformed_frames;
      } else if (heartbeat->node_id == kDeviceNodeId) {
        state->last_heartbeat_time_s = now_s;
        state->device_nmt_state = heartbeat->state;
      }
      break;
    }
    case FrameKind::kEmcy: {
      const Emcy emcy = *DecodeEmcyFrame(frame);
      if (emcy.node_id != kHostNodeId) {
        ++counters_.emcy_received;
        counters_.last_emcy_code = static_cast<std::uint16_t>(emcy.code);
        if (emcy.code == EmcyCode::kHeartbeatLost) {
          state->device_missed_heartbeat = true;  // transient: NMT start brings it back
        } else if (emcy.code != EmcyCode::kNoError) {
          state->device_emergency = true;
        }
      }
      break;
    }
    case FrameKind::kBusError: {
      const BusError error = *DecodeErrorFrame(frame);
      ++counters_.bus_errors;
      state->bus_off = state->bus_off || error.bus_off;
      state->error_passive = state->error_passive || error.error_passive;
      break;
    }
    case FrameKind::kBadLength:
    case FrameKind::kUnknownId:
      ++counters_.malformed_frames;
      break;
    case FrameKind::kNmt:
    case FrameKind::kSync:
    case FrameKind::kMotorPdo:
      break;  // frames of another master: not ours to act on
  }
}

void Ves4Device::Write(double now_s, const MotorCommand& command) {
  MotorVoltages voltages{};
  if (command.powered) {
    // The command is finite and within the loop's OutputLimits (device.h).
    // Feed-forward of the back-EMF from the measured (filtered) speed; the
    // pair saturates at its supply voltage.
    voltages.thrust_V =
        CalcThrustVoltage(params_, command.thrust_force_N, insertion_velocity_m_per_s_);
    voltages.roll_V = CalcRollVoltage(params_, command.roll_torque_Nm, roll_velocity_rad_per_s_);
    voltages.thrust_V = std::clamp(voltages.thrust_V, -params_.thrust.max_voltage_V,
                                   params_.thrust.max_voltage_V);
    voltages.roll_V =
        std::clamp(voltages.roll_V, -params_.roll.max_voltage_V, params_.roll.max_voltage_V);
  }
  last_voltages_ = voltages;
  Send(now_s, EncodeMotorPdo(voltages));
  sync_counter_ = NextSyncCounter(sync_counter_);
  Send(now_s, EncodeSync(sync_counter_));
  if (now_s - last_heartbeat_sent_s_ >= options_.heartbeat_period_s) {
    Send(now_s, EncodeHeartbeat({kHostNodeId, NmtState::kOperational}));
    last_heartbeat_sent_s_ = now_s;
  }
}

void Ves4Device::SendEmergency(double now_s, EmcyCode code) {
  Emcy emcy;
  emcy.node_id = kHostNodeId;
  emcy.code = code;
  emcy.error_register = code == EmcyCode::kNoError ? 0x00 : 0x01;  // generic error bit
  Send(now_s, EncodeEmcy(emcy));
}

void Ves4Device::ClearFaultFlags(DeviceState* state) {
  state->bus_off = false;
  state->error_passive = false;
  state->link_down = false;
  state->device_emergency = false;
  state->device_missed_heartbeat = false;
}

void Ves4Device::SendNmt(double now_s, NmtCommandSpecifier command) {
  Send(now_s, EncodeNmt({command, kDeviceNodeId}));
}

void Ves4Device::Send(double now_s, const can_frame& frame) {
  if (bus_.Write(frame)) {
    ++counters_.frames_sent;
    if (recorder_ != nullptr) recorder_->Record(now_s, frame);
  } else {
    ++counters_.send_failures;
  }
}

}  // namespace ves::haptics
