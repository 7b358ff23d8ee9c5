#include "station/haptics/protocol.h"

#include <linux/can/error.h>

#include <cmath>
#include <limits>
#include <numbers>

namespace ves::haptics {
namespace {

constexpr double kRollCounts_per_rad = kRollCounts_per_rev / (2.0 * std::numbers::pi);

can_frame MakeFrame(canid_t id, std::uint8_t length) {
  can_frame frame{};
  frame.can_id = id;
  frame.can_dlc = length;
  return frame;
}

// Saturating conversion of a scaled value to an integer field; NaN -> 0.
template <typename Int>
Int ToField(double value, double units_per_lsb) {
  if (!std::isfinite(value)) {
    if (std::isnan(value)) return 0;
    return value > 0 ? std::numeric_limits<Int>::max() : std::numeric_limits<Int>::min();
  }
  const double lsb = std::round(value / units_per_lsb);
  if (lsb >= static_cast<double>(std::numeric_limits<Int>::max())) {
    return std::numeric_limits<Int>::max();
  }
  if (lsb <= static_cast<double>(std::numeric_limits<Int>::min())) {
    return std::numeric_limits<Int>::min();
  }
  return static_cast<Int>(lsb);
}

// CANopen fields are little-endian.
void PutU16(std::uint8_t* data, std::uint16_t value) {
  data[0] = static_cast<std::uint8_t>(value & 0xFF);
  data[1] = static_cast<std::uint8_t>(value >> 8);
}
void PutU32(std::uint8_t* data, std::uint32_t value) {
  for (int i = 0; i < 4; ++i) data[i] = static_cast<std::uint8_t>(value >> (8 * i));
}
std::uint16_t GetU16(const std::uint8_t* data) {
  return static_cast<std::uint16_t>(data[0] | (data[1] << 8));
}
std::uint32_t GetU32(const std::uint8_t* data) {
  std::uint32_t value = 0;
  for (int i = 0; i < 4; ++i) value |= static_cast<std::uint32_t>(data[i]) << (8 * i);
  return value;
}

bool IsStandardDataFrame(const can_frame& frame) {
  return (frame.can_id & (CAN_EFF_FLAG | CAN_RTR_FLAG | CAN_ERR_FLAG)) == 0;
}

bool Matches(const can_frame& frame, canid_t id, std::uint8_t length) {
  return IsStandardDataFrame(frame) && (frame.can_id & CAN_SFF_MASK) == id &&
         frame.can_dlc == length;
}

bool IsNodeId(canid_t id) { return id >= 1 && id <= 0x7F; }

}  // namespace

FrameKind ClassifyFrame(const can_frame& frame) {
  if (frame.can_id & CAN_ERR_FLAG) return FrameKind::kBusError;
  if (!IsStandardDataFrame(frame)) return FrameKind::kUnknownId;
  const canid_t id = frame.can_id & CAN_SFF_MASK;
  auto check = [&](FrameKind kind, std::uint8_t length) {
    return frame.can_dlc == length ? kind : FrameKind::kBadLength;
  };
  if (id == kNmtCobId) return check(FrameKind::kNmt, kNmtLength);
  if (id == kSyncCobId) return check(FrameKind::kSync, kSyncLength);
  if (id == kMotorPdoCobId) return check(FrameKind::kMotorPdo, kMotorPdoLength);
  if (id == kEncoderPdoCobId) return check(FrameKind::kEncoderPdo, kEncoderPdoLength);
  if (id == kSensorPdoCobId) return check(FrameKind::kSensorPdo, kSensorPdoLength);
  if (id > kEmcyCobIdBase && IsNodeId(id - kEmcyCobIdBase)) {
    return check(FrameKind::kEmcy, kEmcyLength);
  }
  if (id > kHeartbeatCobIdBase && IsNodeId(id - kHeartbeatCobIdBase)) {
    return check(FrameKind::kHeartbeat, kHeartbeatLength);
  }
  return FrameKind::kUnknownId;
}

double InsertionCountsToMeters(std::int32_t counts) { return counts / kInsertionCounts_per_m; }
double RollCountsToRadians(std::int32_t counts) { return counts / kRollCounts_per_rad; }
std::int32_t MetersToInsertionCounts(double insertion_m) {
  return ToField<std::int32_t>(insertion_m, 1.0 / kInsertionCounts_per_m);
}
std::int32_t RadiansToRollCounts(double roll_rad) {
  return ToField<std::int32_t>(roll_rad, 1.0 / kRollCounts_per_rad);
}

can_frame EncodeNmt(const NmtCommand& command) {
  can_frame frame = MakeFrame(kNmtCobId, kNmtLength);
  frame.data[0] = static_cast<std::uint8_t>(command.command);
  frame.data[1] = command.node_id;
  return frame;
}

can_frame EncodeSync(std::uint8_t counter) {
  can_frame frame = MakeFrame(kSyncCobId, kSyncLength);
  frame.data[0] = counter;
  return frame;
}

can_frame EncodeEmcy(const Emcy& emcy) {
  can_frame frame = MakeFrame(kEmcyCobIdBase + emcy.node_id, kEmcyLength);
  PutU16(frame.data, static_cast<std::uint16_t>(emcy.code));
  frame.data[2] = emcy.error_register;
  for (std::size_t i = 0; i < emcy.detail.size(); ++i) frame.data[3 + i] = emcy.detail[i];
  return frame;
}

can_frame EncodeMotorPdo(const MotorVoltages& voltages) {
  can_frame frame = MakeFrame(kMotorPdoCobId, kMotorPdoLength);
  PutU16(frame.data,
         static_cast<std::uint16_t>(ToField<std::int16_t>(voltages.thrust_V, kMotorVolts_per_lsb)));
  PutU16(frame.data + 2,
         static_cast<std::uint16_t>(ToField<std::int16_t>(voltages.roll_V, kMotorVolts_per_lsb)));
  return frame;
}

can_frame EncodeEncoderPdo(const EncoderCounts& counts) {
  can_frame frame = MakeFrame(kEncoderPdoCobId, kEncoderPdoLength);
  PutU32(frame.data, static_cast<std::uint32_t>(counts.insertion_counts));
  PutU32(frame.data + 4, static_cast<std::uint32_t>(counts.roll_counts));
  return frame;
}

can_frame EncodeSensorPdo(const SensorSample& sample) {
  can_frame frame = MakeFrame(kSensorPdoCobId, kSensorPdoLength);
  PutU16(frame.data,
         static_cast<std::uint16_t>(ToField<std::int16_t>(sample.axial_force_N, kForce_N_per_lsb)));
  PutU16(frame.data + 2, static_cast<std::uint16_t>(
                             ToField<std::int16_t>(sample.axial_torque_Nm, kTorque_Nm_per_lsb)));
  frame.data[4] = sample.sync_counter;
  frame.data[5] = sample.status;
  return frame;
}

can_frame EncodeHeartbeat(const Heartbeat& heartbeat) {
  can_frame frame = MakeFrame(kHeartbeatCobIdBase + heartbeat.node_id, kHeartbeatLength);
  frame.data[0] = static_cast<std::uint8_t>(heartbeat.state);
  return frame;
}

can_frame EncodeBusError(const BusError& error) {
  can_frame frame = MakeFrame(CAN_ERR_FLAG, CAN_ERR_DLC);
  if (error.bus_off) frame.can_id |= CAN_ERR_BUSOFF;
  if (error.error_passive || error.error_warning) {
    frame.can_id |= CAN_ERR_CRTL;
    if (error.error_passive) frame.data[1] |= CAN_ERR_CRTL_RX_PASSIVE | CAN_ERR_CRTL_TX_PASSIVE;
    if (error.error_warning) frame.data[1] |= CAN_ERR_CRTL_RX_WARNING | CAN_ERR_CRTL_TX_WARNING;
  }
  if (error.other) frame.can_id |= CAN_ERR_PROT;
  return frame;
}

std::optional<NmtCommand> DecodeNmtFrame(const can_frame& frame) {
  if (!Matches(frame, kNmtCobId, kNmtLength)) return std::nullopt;
  const std::uint8_t cs = frame.data[0];
  if (cs != 0x01 && cs != 0x02 && cs != 0x80 && cs != 0x81) return std::nullopt;
  return NmtCommand{static_cast<NmtCommandSpecifier>(cs), frame.data[1]};
}

std::optional<std::uint8_t> DecodeSyncFrame(const can_frame& frame) {
  if (!Matches(frame, kSyncCobId, kSyncLength)) return std::nullopt;
  return frame.data[0];
}

std::optional<Emcy> DecodeEmcyFrame(const can_frame& frame) {
  if (ClassifyFrame(frame) != FrameKind::kEmcy) return std::nullopt;
  Emcy emcy;
  emcy.node_id = static_cast<std::uint8_t>((frame.can_id & CAN_SFF_MASK) - kEmcyCobIdBase);
  emcy.code = static_cast<EmcyCode>(GetU16(frame.data));
  emcy.error_register = frame.data[2];
  for (std::size_t i = 0; i < emcy.detail.size(); ++i) emcy.detail[i] = frame.data[3 + i];
  return emcy;
}

std::optional<MotorVoltages> DecodeMotorFrame(const can_frame& frame) {
  if (!Matches(frame, kMotorPdoCobId, kMotorPdoLength)) return std::nullopt;
  return MotorVoltages{static_cast<std::int16_t>(GetU16(frame.data)) * kMotorVolts_per_lsb,
                       static_cast<std::int16_t>(GetU16(frame.data + 2)) * kMotorVolts_per_lsb};
}

std::optional<EncoderCounts> DecodeEncoderFrame(const can_frame& frame) {
  if (!Matches(frame, kEncoderPdoCobId, kEncoderPdoLength)) return std::nullopt;
  return EncoderCounts{static_cast<std::int32_t>(GetU32(frame.data)),
                       static_cast<std::int32_t>(GetU32(frame.data + 4))};
}

std::optional<SensorSample> DecodeSensorFrame(const can_frame& frame) {
  if (!Matches(frame, kSensorPdoCobId, kSensorPdoLength)) return std::nullopt;
  SensorSample sample;
  sample.axial_force_N = static_cast<std::int16_t>(GetU16(frame.data)) * kForce_N_per_lsb;
  sample.axial_torque_Nm = static_cast<std::int16_t>(GetU16(frame.data + 2)) * kTorque_Nm_per_lsb;
  sample.sync_counter = frame.data[4];
  sample.status = frame.data[5];
  return sample;
}

std::optional<Heartbeat> DecodeHeartbeatFrame(const can_frame& frame) {
  if (ClassifyFrame(frame) != FrameKind::kHeartbeat) return std::nullopt;
  const std::uint8_t state = frame.data[0];
  if (state != 0x00 && state != 0x04 && state != 0x05 && state != 0x7F) return std::nullopt;
  return Heartbeat{static_cast<std::uint8_t>((frame.can_id & CAN_SFF_MASK) - kHeartbeatCobIdBase),
                   static_cast<NmtState>(state)};
}

std::optional<BusError> DecodeErrorFrame(const can_frame& frame) {
  if ((frame.can_id & CAN_ERR_FLAG) == 0) return std::nullopt;
  BusError error;
  const canid_t classes = frame.can_id & CAN_ERR_MASK;
  error.bus_off = (classes & CAN_ERR_BUSOFF) != 0;
  if ((classes & CAN_ERR_CRTL) && frame.can_dlc >= 2) {
    const std::uint8_t ctrl = frame.data[1];
    error.error_passive = (ctrl & (CAN_ERR_CRTL_RX_PASSIVE | CAN_ERR_CRTL_TX_PASSIVE)) != 0;
    error.error_warning = (ctrl & (CAN_ERR_CRTL_RX_WARNING | CAN_ERR_CRTL_TX_WARNING)) != 0;
  }
  error.other = (classes & ~(CAN_ERR_BUSOFF | CAN_ERR_CRTL)) != 0;
  return error;
}

std::uint8_t NextSyncCounter(std::uint8_t counter) {
  return counter >= kSyncCounterMax ? 1 : static_cast<std::uint8_t>(counter + 1);
}

int SyncCounterGap(std::uint8_t previous, std::uint8_t next) {
  // Counters run 1..240; distance forward from previous to next, minus one.
  const int distance =
      (static_cast<int>(next) - static_cast<int>(previous) + kSyncCounterMax) % kSyncCounterMax;
  return distance == 0 ? kSyncCounterMax - 1 : distance - 1;
}

}  // namespace ves::haptics
