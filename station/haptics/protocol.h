#pragma once

// The VES-IV device protocol on CAN (docs/can-protocol.md), CANopen style:
// NMT, SYNC-driven cyclic PDOs, heartbeat both ways, EMCY, error frames.
// Every function here is pure: frames in, SI values out (and back), so the
// whole protocol is tested without sockets.
#include <linux/can.h>

#include <array>
#include <cstdint>
#include <optional>

namespace ves::haptics {

// Node ids: the station (NMT master, SYNC producer) and the ball drive.
inline constexpr std::uint8_t kHostNodeId = 0x01;
inline constexpr std::uint8_t kDeviceNodeId = 0x10;

// COB-IDs (11-bit), CANopen pre-defined connection set.
inline constexpr canid_t kNmtCobId = 0x000;
inline constexpr canid_t kSyncCobId = 0x080;
inline constexpr canid_t kEmcyCobIdBase = 0x080;                    // + node id
inline constexpr canid_t kEncoderPdoCobId = 0x180 + kDeviceNodeId;  // TPDO1, device -> host
inline constexpr canid_t kSensorPdoCobId = 0x280 + kDeviceNodeId;   // TPDO2, device -> host
inline constexpr canid_t kMotorPdoCobId = 0x200 + kDeviceNodeId;    // RPDO1, host -> device
inline constexpr canid_t kHeartbeatCobIdBase = 0x700;               // + node id

// Frame lengths (DLC). A frame of a known id with another length is malformed.
inline constexpr std::uint8_t kNmtLength = 2;
inline constexpr std::uint8_t kSyncLength = 1;
inline constexpr std::uint8_t kEmcyLength = 8;
inline constexpr std::uint8_t kEncoderPdoLength = 8;
inline constexpr std::uint8_t kSensorPdoLength = 6;
inline constexpr std::uint8_t kMotorPdoLength = 4;
inline constexpr std::uint8_t kHeartbeatLength = 1;

// Scaling of every field: the only place counts and SI meet.
inline constexpr double kMotorVolts_per_lsb = 1e-3;     // int16, mV
inline constexpr double kForce_N_per_lsb = 1e-3;        // int16, mN
inline constexpr double kTorque_Nm_per_lsb = 1e-4;      // int16, 0.1 mN·m
inline constexpr double kInsertionCounts_per_m = 1e6;   // int32, 1 µm per count
inline constexpr double kRollCounts_per_rev = 65536.0;  // int32, 16 bit per scope turn
inline constexpr std::uint8_t kSyncCounterMax = 240;    // CANopen SYNC counter 1..240

enum class NmtCommandSpecifier : std::uint8_t {
  kStart = 0x01,
  kStop = 0x02,
  kEnterPreOperational = 0x80,
  kResetNode = 0x81,
};

enum class NmtState : std::uint8_t {
  kBootUp = 0x00,
  kStopped = 0x04,
  kOperational = 0x05,
  kPreOperational = 0x7F,
};

// EMCY error codes (CANopen DS301 classes; 0xFFxx manufacturer specific).
enum class EmcyCode : std::uint16_t {
  kNoError = 0x0000,
  kCurrentExceeded = 0x2310,
  kSoftwareNonFinite = 0x6100,
  kCanOverrun = 0x8110,
  kCanErrorPassive = 0x8120,
  kHeartbeatLost = 0x8130,
  kCanBusOff = 0x8140,
  kSensorTimeout = 0xFF01,
  kModelStalled = 0xFF02,
  kDeviceReported = 0xFF03,  // the station echoes that the device sent an EMCY
};

struct NmtCommand {
  NmtCommandSpecifier command{NmtCommandSpecifier::kStart};
  std::uint8_t node_id{kDeviceNodeId};  // 0 = all nodes
  bool operator==(const NmtCommand&) const = default;
};

struct Heartbeat {
  std::uint8_t node_id{0};
  NmtState state{NmtState::kBootUp};
  bool operator==(const Heartbeat&) const = default;
};

struct Emcy {
  std::uint8_t node_id{0};
  EmcyCode code{EmcyCode::kNoError};
  std::uint8_t error_register{0};
  std::array<std::uint8_t, 5> detail{};
  bool operator==(const Emcy&) const = default;
};

// RPDO1: the voltage applied to each motor pair (both motors of a pair get
// the same voltage, paper §2.1 item 5).
struct MotorVoltages {
  double thrust_V{0.0};
  double roll_V{0.0};
  bool operator==(const MotorVoltages&) const = default;
};

// TPDO1: raw encoder counts, converted to SI by the driver.
struct EncoderCounts {
  std::int32_t insertion_counts{0};
  std::int32_t roll_counts{0};
  bool operator==(const EncoderCounts&) const = default;
};

// TPDO2: the 6-axis sensor's axial force and torque about the scope axis.
struct SensorSample {
  double axial_force_N{0.0};
  double axial_torque_Nm{0.0};
  std::uint8_t sync_counter{0};  // the SYNC this sample answers
  std::uint8_t status{0};        // kStatus* bits
  bool operator==(const SensorSample&) const = default;
};
inline constexpr std::uint8_t kStatusOperational = 0x01;
inline constexpr std::uint8_t kStatusMotorsEnabled = 0x02;
inline constexpr std::uint8_t kStatusSensorSaturated = 0x04;

// What a SocketCAN error frame says (CAN_ERR_FLAG frames, <linux/can/error.h>).
struct BusError {
  bool bus_off{false};
  bool error_passive{false};
  bool error_warning{false};
  bool other{false};  // any other error class (protocol, ack, lost arbitration ...)
  bool operator==(const BusError&) const = default;
};

enum class FrameKind {
  kNmt,
  kSync,
  kEmcy,
  kMotorPdo,
  kEncoderPdo,
  kSensorPdo,
  kHeartbeat,
  kBusError,
  kUnknownId,  // not in our frame set (also extended or RTR frames)
  kBadLength,  // a known id with the wrong DLC
};

// Which frame of our set this is, checking id and length.
FrameKind ClassifyFrame(const can_frame& frame);

// Unit conversions, counts <-> SI.
double InsertionCountsToMeters(std::int32_t counts);
double RollCountsToRadians(std::int32_t counts);
std::int32_t MetersToInsertionCounts(double insertion_m);
std::int32_t RadiansToRollCounts(double roll_rad);

// Encoders: out-of-range and non-finite values saturate / become 0, never UB.
can_frame EncodeNmt(const NmtCommand& command);
can_frame EncodeSync(std::uint8_t counter);
can_frame EncodeEmcy(const Emcy& emcy);
can_frame EncodeMotorPdo(const MotorVoltages& voltages);
can_frame EncodeEncoderPdo(const EncoderCounts& counts);
can_frame EncodeSensorPdo(const SensorSample& sample);
can_frame EncodeHeartbeat(const Heartbeat& heartbeat);
can_frame EncodeBusError(const BusError& error);  // what the kernel would deliver

// Decoders: std::nullopt when the frame is not that message (id or length).
std::optional<NmtCommand> DecodeNmtFrame(const can_frame& frame);
std::optional<std::uint8_t> DecodeSyncFrame(const can_frame& frame);
std::optional<Emcy> DecodeEmcyFrame(const can_frame& frame);
std::optional<MotorVoltages> DecodeMotorFrame(const can_frame& frame);
std::optional<EncoderCounts> DecodeEncoderFrame(const can_frame& frame);
std::optional<SensorSample> DecodeSensorFrame(const can_frame& frame);
std::optional<Heartbeat> DecodeHeartbeatFrame(const can_frame& frame);
std::optional<BusError> DecodeErrorFrame(const can_frame& frame);

// Next SYNC counter value after `counter` (1..240, wrapping).
std::uint8_t NextSyncCounter(std::uint8_t counter);
// Frames missing between two SYNC counters (0 when `next` follows `previous`).
int SyncCounterGap(std::uint8_t previous, std::uint8_t next);

}  // namespace ves::haptics
