// Ves4Device <-> SimulatedBallDrive over the socketpair, frame type by frame
// type, stepping both by hand (no threads, no clocks).
#include <gtest/gtest.h>
#include <sys/socket.h>

#include <cmath>
#include <numbers>

#include "station/haptics/simulated_ball_drive.h"
#include "station/haptics/ves4_device.h"

namespace ves::haptics {
namespace {

constexpr double kPeriod_s = 0.001;
constexpr double kInsertionTolerance_m = 1e-6;                           // 1 count
constexpr double kRollTolerance_rad = 2.0 * std::numbers::pi / 65536.0;  // 1 count
constexpr double kForceTolerance_N = 1e-3;                               // 1 LSB, no noise

class DriverWithSimulatedDevice : public ::testing::Test {
 protected:
  DriverWithSimulatedDevice() {
    auto [host, device] = CanBus::CreateSocketPair();
    SimulatedBallDriveOptions options;
    options.force_noise_N = 0.0;
    options.torque_noise_Nm = 0.0;
    // A hand holding the scope 5 mm / 0.1 rad forward of where it starts.
    options.hand.thrust.offset = 0.005;
    options.hand.roll.offset = 0.1;
    driver_ = std::make_unique<Ves4Device>(std::move(host), options.params);
    device_ = std::make_unique<SimulatedBallDrive>(std::move(device), options);
  }

  // One period: station writes, device answers, station reads.
  void Period(const MotorCommand& command) {
    driver_->Write(now_s_, command);
    device_->Service(now_s_);
    now_s_ += kPeriod_s;
    driver_->Read(now_s_, &state_);
  }

  void Start() {
    device_->Service(now_s_);
    driver_->SendNmt(now_s_, NmtCommandSpecifier::kStart);
    Period(MotorCommand{});
  }

  std::unique_ptr<Ves4Device> driver_;
  std::unique_ptr<SimulatedBallDrive> device_;
  DeviceState state_{};
  double now_s_{0.0};
};

TEST_F(DriverWithSimulatedDevice, BootUpHeartbeatThenNmtStartMakesTheDeviceOperational) {
  device_->Service(now_s_);
  driver_->Read(now_s_, &state_);
  EXPECT_EQ(state_.device_nmt_state, NmtState::kBootUp);
  EXPECT_EQ(state_.last_heartbeat_time_s, now_s_);
  EXPECT_EQ(device_->nmt_state(), NmtState::kPreOperational);
  Period(MotorCommand{});  // pre-operational: SYNC answered with no PDO
  EXPECT_EQ(state_.last_sensor_time_s, kNever_s);
  driver_->SendNmt(now_s_, NmtCommandSpecifier::kStart);
  Period(MotorCommand{});
  EXPECT_EQ(device_->nmt_state(), NmtState::kOperational);
  EXPECT_EQ(state_.last_sensor_time_s, now_s_);
  EXPECT_EQ(state_.last_encoder_time_s, now_s_);
}

TEST_F(DriverWithSimulatedDevice, MotorPdoReachesThePairsAndSyncStepsThePlant) {
  Start();
  const std::uint64_t syncs = device_->syncs();
  MotorCommand command{2.0, 0.05, true};
  Period(command);
  EXPECT_EQ(device_->syncs(), syncs + 1);
  // The device applies exactly the voltages the driver computed (to 1 mV).
  EXPECT_NEAR(device_->applied_voltages().thrust_V, driver_->last_voltages().thrust_V, 1e-3);
  EXPECT_NEAR(device_->applied_voltages().roll_V, driver_->last_voltages().roll_V, 1e-3);
  // Scope at rest: V = R·F·r/(2·k_t·G) = 8·2·0.01/(2·0.01·10) = 0.8 V.
  EXPECT_NEAR(driver_->last_voltages().thrust_V, 0.8, 0.05);
}

TEST_F(DriverWithSimulatedDevice, EncoderAndSensorPdosArriveInSiUnits) {
  Start();
  for (int i = 0; i < 300; ++i) Period(MotorCommand{});
  const PlantState& plant = device_->plant();
  EXPECT_NEAR(state_.insertion_m, plant.insertion_m, kInsertionTolerance_m);
  EXPECT_NEAR(state_.roll_rad, plant.roll_motor_rad, kRollTolerance_rad);
  EXPECT_NEAR(state_.force_N, plant.hand_force_N, kForceTolerance_N);
  EXPECT_NEAR(state_.torque_Nm, plant.hand_torque_Nm, 1e-4);
  // Unpowered, the hand has pulled the scope toward its 5 mm target.
  EXPECT_GT(state_.insertion_m, 0.001);
  EXPECT_EQ(driver_->counters().lost_frames, 0u);
  EXPECT_EQ(driver_->counters().malformed_frames, 0u);
}

TEST_F(DriverWithSimulatedDevice, HeartbeatsFlowBothWays) {
  Start();
  for (int i = 0; i < 50; ++i) Period(MotorCommand{});
  // 10 ms heartbeat period: ~5 each way in 50 ms.
  EXPECT_GE(device_->host_heartbeats(), 4u);
  EXPECT_GE(now_s_ - state_.last_heartbeat_time_s, 0.0);
  EXPECT_LE(now_s_ - state_.last_heartbeat_time_s, 0.011);
  EXPECT_EQ(state_.device_nmt_state, NmtState::kOperational);
}

TEST_F(DriverWithSimulatedDevice, EmcyFromTheStationReachesTheDevice) {
  Start();
  driver_->SendEmergency(now_s_, EmcyCode::kSensorTimeout);
  Period(MotorCommand{});
  ASSERT_EQ(device_->received_emcy().size(), 1u);
  EXPECT_EQ(device_->received_emcy()[0].code, EmcyCode::kSensorTimeout);
  EXPECT_EQ(device_->received_emcy()[0].node_id, kHostNodeId);
}

TEST_F(DriverWithSimulatedDevice, DeviceCutsMotorsAndSendsEmcyWhenStationHeartbeatStops) {
  Start();
  for (int i = 0; i < 20; ++i) Period(MotorCommand{1.0, 0.0, true});
  EXPECT_NE(device_->applied_voltages().thrust_V, 0.0);
  // The station stops talking (no SYNC, no heartbeat); the device keeps time.
  for (int i = 0; i < 30; ++i) {
    now_s_ += kPeriod_s;
    device_->Service(now_s_);
  }
  EXPECT_TRUE(device_->host_heartbeat_lost());
  driver_->Read(now_s_, &state_);
  EXPECT_EQ(driver_->counters().emcy_received, 1u);
  EXPECT_EQ(driver_->counters().last_emcy_code,
            static_cast<std::uint16_t>(EmcyCode::kHeartbeatLost));
  Period(MotorCommand{1.0, 0.0, true});  // ignored until NMT start again
  EXPECT_EQ(device_->applied_voltages().thrust_V, 0.0);
}

TEST_F(DriverWithSimulatedDevice, NmtStopSilencesPdosAndUnpowersTheMotors) {
  Start();
  Period(MotorCommand{1.0, 0.0, true});
  driver_->SendNmt(now_s_, NmtCommandSpecifier::kStop);
  const double stopped_at_s = now_s_;
  Period(MotorCommand{1.0, 0.0, true});
  Period(MotorCommand{1.0, 0.0, true});
  EXPECT_EQ(device_->nmt_state(), NmtState::kStopped);
  EXPECT_EQ(device_->applied_voltages().thrust_V, 0.0);
  EXPECT_LE(state_.last_sensor_time_s, stopped_at_s + kPeriod_s);
}

TEST_F(DriverWithSimulatedDevice, ErrorFramesAreCountedAndFlagged) {
  Start();
  device_->SendBusError({.error_warning = true});
  Period(MotorCommand{});
  EXPECT_EQ(driver_->counters().bus_errors, 1u);
  EXPECT_FALSE(state_.bus_off);
  EXPECT_FALSE(state_.error_passive);
  device_->SendBusError({.error_passive = true});
  device_->SendBusError({.bus_off = true});
  Period(MotorCommand{});
  EXPECT_EQ(driver_->counters().bus_errors, 3u);
  EXPECT_TRUE(state_.error_passive);
  EXPECT_TRUE(state_.bus_off);
  driver_->ClearFaultFlags(&state_);
  EXPECT_FALSE(state_.bus_off);
}

TEST_F(DriverWithSimulatedDevice, MalformedFramesAreCountedAndIgnored) {
  Start();
  Period(MotorCommand{});
  const DeviceState before = state_;
  can_frame wrong_length = EncodeSensorPdo({9.0, 0.0, 1, 0});
  wrong_length.can_dlc = 3;
  can_frame unknown{};
  unknown.can_id = 0x3FF;
  unknown.can_dlc = 8;
  can_frame too_long_encoder = EncodeEncoderPdo({999999, 0});
  too_long_encoder.can_dlc = 7;
  device_->SendRawFrame(wrong_length);
  device_->SendRawFrame(unknown);
  device_->SendRawFrame(too_long_encoder);
  // A record that is not a can_frame at all.
  const unsigned char junk[3] = {0xAA, 0xBB, 0xCC};
  ASSERT_EQ(send(device_->bus_fd(), junk, sizeof(junk), 0), 3);
  driver_->Read(now_s_, &state_);
  EXPECT_EQ(driver_->counters().malformed_frames, 4u);
  EXPECT_EQ(state_.force_N, before.force_N);
  EXPECT_EQ(state_.insertion_m, before.insertion_m);
  // The station keeps working.
  Period(MotorCommand{});
  EXPECT_EQ(state_.last_sensor_time_s, now_s_);
}

TEST_F(DriverWithSimulatedDevice, LostSensorPdosAreCountedFromSyncCounterGaps) {
  Start();
  Period(MotorCommand{});
  device_->set_faults({.mute_sensor_pdo = true});
  for (int i = 0; i < 10; ++i) Period(MotorCommand{});
  device_->set_faults({});
  Period(MotorCommand{});
  EXPECT_EQ(driver_->counters().lost_frames, 10u);
}

}  // namespace
}  // namespace ves::haptics
