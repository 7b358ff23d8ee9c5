// Pure encode/decode of every frame of docs/can-protocol.md, no sockets.
#include "station/haptics/protocol.h"

#include <gtest/gtest.h>
#include <linux/can/error.h>

#include <cmath>
#include <limits>
#include <numbers>

namespace ves::haptics {
namespace {

constexpr double kVoltTolerance_V = 0.5e-3;  // half an LSB
constexpr double kForceTolerance_N = 0.5e-3;
constexpr double kTorqueTolerance_Nm = 0.5e-4;

TEST(Protocol, MotorPdoRoundTripsInMillivoltsLittleEndian) {
  const can_frame frame = EncodeMotorPdo({1.234, -2.5});
  EXPECT_EQ(frame.can_id, 0x210u);
  EXPECT_EQ(frame.can_dlc, kMotorPdoLength);
  // 1234 mV = 0x04D2 -> D2 04; -2500 mV = 0xF63C -> 3C F6.
  EXPECT_EQ(frame.data[0], 0xD2);
  EXPECT_EQ(frame.data[1], 0x04);
  EXPECT_EQ(frame.data[2], 0x3C);
  EXPECT_EQ(frame.data[3], 0xF6);
  const auto decoded = DecodeMotorFrame(frame);
  ASSERT_TRUE(decoded.has_value());
  EXPECT_NEAR(decoded->thrust_V, 1.234, kVoltTolerance_V);
  EXPECT_NEAR(decoded->roll_V, -2.5, kVoltTolerance_V);
}

TEST(Protocol, OutOfRangeAndNonFiniteValuesSaturateOrBecomeZero) {
  const auto decoded = DecodeMotorFrame(EncodeMotorPdo({1e9, std::nan("")}));
  ASSERT_TRUE(decoded.has_value());
  EXPECT_NEAR(decoded->thrust_V, 32.767, kVoltTolerance_V);  // int16 max in mV
  EXPECT_EQ(decoded->roll_V, 0.0);
  const auto negative =
      DecodeMotorFrame(EncodeMotorPdo({-std::numeric_limits<double>::infinity(), 0.0}));
  EXPECT_NEAR(negative->thrust_V, -32.768, kVoltTolerance_V);
}

TEST(Protocol, EncoderPdoCarriesSignedCountsAndConvertsToSi) {
  const EncoderCounts counts{-123456, 65536};
  const auto decoded = DecodeEncoderFrame(EncodeEncoderPdo(counts));
  ASSERT_TRUE(decoded.has_value());
  EXPECT_EQ(*decoded, counts);
  // 1 µm per count; 65536 counts per turn.
  EXPECT_DOUBLE_EQ(InsertionCountsToMeters(-123456), -0.123456);
  EXPECT_NEAR(RollCountsToRadians(65536), 2.0 * std::numbers::pi, 1e-12);
  EXPECT_EQ(MetersToInsertionCounts(0.0105), 10500);
  EXPECT_EQ(RadiansToRollCounts(std::numbers::pi), 32768);
}

TEST(Protocol, SensorPdoRoundTripsForceTorqueCounterAndStatus) {
  SensorSample sample;
  sample.axial_force_N = -3.21;
  sample.axial_torque_Nm = 0.1234;
  sample.sync_counter = 17;
  sample.status = kStatusOperational | kStatusMotorsEnabled;
  const can_frame frame = EncodeSensorPdo(sample);
  EXPECT_EQ(frame.can_id, 0x290u);
  EXPECT_EQ(frame.can_dlc, kSensorPdoLength);
  const auto decoded = DecodeSensorFrame(frame);
  ASSERT_TRUE(decoded.has_value());
  EXPECT_NEAR(decoded->axial_force_N, -3.21, kForceTolerance_N);
  EXPECT_NEAR(decoded->axial_torque_Nm, 0.1234, kTorqueTolerance_Nm);
  EXPECT_EQ(decoded->sync_counter, 17);
  EXPECT_EQ(decoded->status, sample.status);
}

TEST(Protocol, NmtSyncHeartbeatAndEmcyRoundTrip) {
  const NmtCommand start{NmtCommandSpecifier::kStart, kDeviceNodeId};
  const can_frame nmt = EncodeNmt(start);
  EXPECT_EQ(nmt.can_id, 0x000u);
  EXPECT_EQ(DecodeNmtFrame(nmt), start);

  EXPECT_EQ(EncodeSync(9).can_id, 0x080u);
  EXPECT_EQ(DecodeSyncFrame(EncodeSync(9)), 9);

  const Heartbeat heartbeat{kDeviceNodeId, NmtState::kOperational};
  const can_frame beat = EncodeHeartbeat(heartbeat);
  EXPECT_EQ(beat.can_id, 0x710u);
  EXPECT_EQ(beat.data[0], 0x05);
  EXPECT_EQ(DecodeHeartbeatFrame(beat), heartbeat);

  Emcy emcy;
  emcy.node_id = kHostNodeId;
  emcy.code = EmcyCode::kSensorTimeout;
  emcy.error_register = 0x01;
  emcy.detail = {1, 2, 3, 4, 5};
  const can_frame frame = EncodeEmcy(emcy);
  EXPECT_EQ(frame.can_id, 0x081u);
  EXPECT_EQ(frame.data[0], 0x01);  // 0xFF01 little-endian
  EXPECT_EQ(frame.data[1], 0xFF);
  EXPECT_EQ(DecodeEmcyFrame(frame), emcy);
}

TEST(Protocol, ErrorFramesReportBusOffAndErrorPassive) {
  const auto bus_off = DecodeErrorFrame(EncodeBusError({.bus_off = true}));
  ASSERT_TRUE(bus_off.has_value());
  EXPECT_TRUE(bus_off->bus_off);
  EXPECT_FALSE(bus_off->error_passive);

  // As the kernel delivers it: CAN_ERR_CRTL class, controller status in data[1].
  can_frame passive{};
  passive.can_id = CAN_ERR_FLAG | CAN_ERR_CRTL;
  passive.can_dlc = CAN_ERR_DLC;
  passive.data[1] = CAN_ERR_CRTL_TX_PASSIVE;
  const auto decoded = DecodeErrorFrame(passive);
  ASSERT_TRUE(decoded.has_value());
  EXPECT_TRUE(decoded->error_passive);
  EXPECT_FALSE(decoded->bus_off);
  EXPECT_EQ(ClassifyFrame(passive), FrameKind::kBusError);
  EXPECT_FALSE(DecodeErrorFrame(EncodeSync(1)).has_value());
}

TEST(Protocol, WrongLengthAndUnknownIdsAreClassifiedNotDecoded) {
  can_frame short_sensor = EncodeSensorPdo({});
  short_sensor.can_dlc = 5;
  EXPECT_EQ(ClassifyFrame(short_sensor), FrameKind::kBadLength);
  EXPECT_FALSE(DecodeSensorFrame(short_sensor).has_value());

  can_frame unknown{};
  unknown.can_id = 0x555;
  unknown.can_dlc = 8;
  EXPECT_EQ(ClassifyFrame(unknown), FrameKind::kUnknownId);

  can_frame extended = EncodeEncoderPdo({});
  extended.can_id |= CAN_EFF_FLAG;
  EXPECT_EQ(ClassifyFrame(extended), FrameKind::kUnknownId);
  EXPECT_FALSE(DecodeEncoderFrame(extended).has_value());

  can_frame bad_state = EncodeHeartbeat({kDeviceNodeId, NmtState::kOperational});
  bad_state.data[0] = 0x42;
  EXPECT_FALSE(DecodeHeartbeatFrame(bad_state).has_value());
}

TEST(Protocol, SyncCounterWrapsAt240AndGapsCountMissingFrames) {
  EXPECT_EQ(NextSyncCounter(0), 1);
  EXPECT_EQ(NextSyncCounter(239), 240);
  EXPECT_EQ(NextSyncCounter(240), 1);
  EXPECT_EQ(SyncCounterGap(5, 6), 0);
  EXPECT_EQ(SyncCounterGap(5, 9), 3);
  EXPECT_EQ(SyncCounterGap(239, 2), 2);  // 240 and 1 missing
}

}  // namespace
}  // namespace ves::haptics
