// Each safety rule: inject the fault, check zero output (0 V on both pairs)
// within one period of the rule's deadline and EMCY on the bus; a hard fault
// is left only by an explicit re-arm, a transient one (a communication gap
// under 100 ms) clears by itself and fades the output back in. Stalls of the
// station (its loop, or the whole process) are not silence of the device.
#include <gtest/gtest.h>
#include <sys/socket.h>

#include <cmath>
#include <limits>
#include <vector>

#include "station/haptics/haptic_cycle.h"
#include "station/haptics/sim_rig.h"
#include "tests/station/haptics/scripted_source.h"

namespace ves::haptics {
namespace {

constexpr double kPeriod_s = 0.001;
constexpr int kPeriodsAfterFaultCleared = 200;

SimulatedRigOptions HoldingHand(ControlMode mode) {
  SimulatedRigOptions options;
  options.device.hand.thrust.amplitude = 0.005;
  options.device.hand.thrust.frequency_Hz = 1.0;
  options.cycle.control.mode = mode;
  return options;
}

bool IsZeroOutput(SimulatedRig& rig, const CycleOutput& output) {
  return !output.command.powered && rig.driver().last_voltages() == MotorVoltages{};
}

// Steps until the cycle reports a fault; returns the number of steps (or -1).
int StepsUntilFault(SimulatedRig& rig, int max_steps, CycleOutput* at_fault) {
  for (int step = 1; step <= max_steps; ++step) {
    const CycleOutput& output = rig.Step();
    if (output.fault != SafetyFault::kNone) {
      *at_fault = output;
      return step;
    }
    EXPECT_TRUE(output.command.powered) << "unpowered before the fault, step " << step;
  }
  return -1;
}

// After the cause is gone: stays safe for many periods, re-arm leaves it.
void ExpectOnlyRearmLeavesSafeState(SimulatedRig& rig, SafetyFault fault) {
  for (int i = 0; i < kPeriodsAfterFaultCleared; ++i) {
    const CycleOutput& output = rig.Step();
    ASSERT_EQ(output.fault, fault) << "left the safe state by itself after " << i << " periods";
    ASSERT_TRUE(IsZeroOutput(rig, output));
  }
  rig.Rearm();
  const CycleOutput& output = rig.Step();
  EXPECT_EQ(output.fault, SafetyFault::kNone);
  EXPECT_TRUE(output.command.powered);
}

void ExpectEmcyAtDevice(SimulatedRig& rig, EmcyCode code) {
  rig.Step();  // the device reads the EMCY sent in the fault period
  ASSERT_FALSE(rig.device().received_emcy().empty());
  EXPECT_EQ(rig.device().received_emcy().back().code, code);
  EXPECT_EQ(rig.device().received_emcy().back().node_id, kHostNodeId);
}

// Steps until the output is powered again; returns the steps (or -1).
int StepsUntilPowered(SimulatedRig& rig, int max_steps) {
  for (int step = 1; step <= max_steps; ++step) {
    const CycleOutput& output = rig.Step();
    if (output.command.powered) return step;
    EXPECT_TRUE(IsTransient(output.fault) || output.fault == SafetyFault::kNone)
        << ToString(output.fault) << " at step " << step;
  }
  return -1;
}

// After a transient fault: without a re-arm the output comes back once the
// bus has been healthy for healthy_before_fade_s, starting from zero and
// rising to full over fade_in_s.
void ExpectRecoversWithoutRearm(SimulatedRig& rig) {
  const SafetyLimits& limits = rig.cycle().options().safety;
  const int healthy_periods = static_cast<int>(std::lround(limits.healthy_before_fade_s / kPeriod_s));
  const int steps = StepsUntilPowered(rig, 2 * healthy_periods + 20);
  ASSERT_GT(steps, 0) << "did not recover without a re-arm";
  EXPECT_GE(steps, healthy_periods) << "output came back before the bus was healthy for long";
  EXPECT_EQ(rig.cycle().output().fault, SafetyFault::kNone);
  double previous_scale = rig.cycle().output().output_scale;
  EXPECT_LT(previous_scale, 0.05);  // fades in from zero, no step
  const int fade_periods = static_cast<int>(std::lround(limits.fade_in_s / kPeriod_s));
  for (int i = 0; i < fade_periods + 5; ++i) {
    const CycleOutput& output = rig.Step();
    ASSERT_EQ(output.fault, SafetyFault::kNone) << "period " << i << " of the fade";
    ASSERT_GE(output.output_scale, previous_scale);
    previous_scale = output.output_scale;
  }
  EXPECT_EQ(previous_scale, 1.0);
  EXPECT_EQ(rig.cycle().safety().hard_faults(), 0u);
}

TEST(Safety, StartsSafeUntilArmed) {
  SimulatedRig rig(HoldingHand(ControlMode::kFree));
  const CycleOutput& output = rig.Step();
  EXPECT_EQ(output.fault, SafetyFault::kNotArmed);
  EXPECT_TRUE(IsZeroOutput(rig, output));
  ASSERT_TRUE(rig.BringUp());
  EXPECT_TRUE(rig.Step().command.powered);
}

TEST(Safety, SilentSensorWithTheLoopOnTimeGivesZeroOutputWithin5Ms) {
  SimulatedRig rig(HoldingHand(ControlMode::kFree));
  ASSERT_TRUE(rig.BringUp());
  for (int i = 0; i < 20; ++i) rig.Step();
  rig.device().set_faults({.mute_sensor_pdo = true});
  CycleOutput at_fault;
  const int steps = StepsUntilFault(rig, 100, &at_fault);
  // The last sensor frame was read in the first step after muting; 5 periods
  // later the sensor has been silent for 5 ms.
  EXPECT_EQ(steps, 6);
  EXPECT_EQ(at_fault.fault, SafetyFault::kSensorTimeout);
  EXPECT_TRUE(IsTransient(at_fault.fault));
  EXPECT_TRUE(IsZeroOutput(rig, at_fault));
  ExpectEmcyAtDevice(rig, EmcyCode::kSensorTimeout);
  // A gap of 40 ms in all: transient.
  for (int i = 0; i < 33; ++i) ASSERT_TRUE(IsZeroOutput(rig, rig.Step()));
  rig.device().set_faults({});
  ExpectRecoversWithoutRearm(rig);
  EXPECT_EQ(rig.cycle().safety().transient_faults(), 1u);
  EXPECT_EQ(rig.cycle().safety().recoveries(), 1u);
}

TEST(Safety, LongSensorSilenceIsAHardFault) {
  SimulatedRig rig(HoldingHand(ControlMode::kFree));
  ASSERT_TRUE(rig.BringUp());
  rig.device().set_faults({.mute_sensor_pdo = true});
  CycleOutput at_fault;
  ASSERT_GT(StepsUntilFault(rig, 100, &at_fault), 0);
  EXPECT_EQ(at_fault.fault, SafetyFault::kSensorTimeout);
  // Still silent 100 ms after the trip: communication lost, a re-arm by hand.
  int steps = 0;
  while (rig.cycle().output().fault == SafetyFault::kSensorTimeout && steps < 500) {
    ASSERT_TRUE(IsZeroOutput(rig, rig.Step()));
    ++steps;
  }
  EXPECT_EQ(steps, 100);
  EXPECT_EQ(rig.cycle().output().fault, SafetyFault::kCommunicationLost);
  EXPECT_FALSE(IsTransient(SafetyFault::kCommunicationLost));
  rig.device().set_faults({});
  ExpectOnlyRearmLeavesSafeState(rig, SafetyFault::kCommunicationLost);
  EXPECT_EQ(rig.cycle().safety().hard_faults(), 1u);
}

// A short drop-out while the bus recovers restarts the wait for a healthy
// bus but is no long silence: still no re-arm needed.
TEST(Safety, ABriefDropOutWhileRecoveringIsStillTransient) {
  SimulatedRig rig(HoldingHand(ControlMode::kFree));
  ASSERT_TRUE(rig.BringUp());
  rig.device().set_faults({.mute_sensor_pdo = true});
  for (int i = 0; i < 30; ++i) rig.Step();
  EXPECT_EQ(rig.cycle().output().fault, SafetyFault::kSensorTimeout);
  rig.device().set_faults({});
  for (int i = 0; i < 40; ++i) ASSERT_EQ(rig.Step().fault, SafetyFault::kSensorTimeout);
  rig.device().set_faults({.mute_sensor_pdo = true});
  for (int i = 0; i < 8; ++i) rig.Step();
  rig.device().set_faults({});
  ExpectRecoversWithoutRearm(rig);
  EXPECT_EQ(rig.cycle().safety().transient_faults(), 1u);
}

// A bus that keeps dropping out never gives 50 ms of health: after 1 s the
// fault is no longer transient.
TEST(Safety, ABusThatKeepsDroppingOutBecomesAHardFault) {
  SimulatedRig rig(HoldingHand(ControlMode::kFree));
  ASSERT_TRUE(rig.BringUp());
  const double limit_s = rig.cycle().options().safety.max_transient_s;
  ASSERT_EQ(rig.Step().fault, SafetyFault::kNone);
  int steps = 0;
  while (rig.cycle().output().fault != SafetyFault::kCommunicationLost && steps < 3000) {
    rig.device().set_faults({.mute_sensor_pdo = (steps % 40) < 10});  // 10 ms of every 40
    const SafetyFault fault = rig.cycle().output().fault;
    ASSERT_TRUE(fault == SafetyFault::kNone || IsTransient(fault)) << ToString(fault);
    rig.Step();
    ++steps;
  }
  EXPECT_EQ(rig.cycle().output().fault, SafetyFault::kCommunicationLost);
  EXPECT_GE(steps * kPeriod_s, limit_s);
  EXPECT_LE(steps * kPeriod_s, limit_s + 0.05);
  EXPECT_EQ(rig.cycle().safety().recoveries(), 0u);
}

TEST(Safety, SilentEncoderAlsoCountsAsSilentSensor) {
  SimulatedRig rig(HoldingHand(ControlMode::kFree));
  ASSERT_TRUE(rig.BringUp());
  rig.device().set_faults({.mute_encoder_pdo = true});
  CycleOutput at_fault;
  EXPECT_LE(StepsUntilFault(rig, 100, &at_fault), 6);
  EXPECT_EQ(at_fault.fault, SafetyFault::kSensorTimeout);
  EXPECT_TRUE(IsZeroOutput(rig, at_fault));
}

TEST(Safety, MissedDeviceHeartbeatGivesZeroOutputWithinOnePeriodOfTimeout) {
  auto options = HoldingHand(ControlMode::kFree);
  SimulatedRig rig(options);
  ASSERT_TRUE(rig.BringUp());
  for (int i = 0; i < 20; ++i) rig.Step();
  rig.device().set_faults({.mute_heartbeat = true});
  const double last_heartbeat_s = rig.cycle().device_state().last_heartbeat_time_s;
  CycleOutput at_fault;
  ASSERT_GT(StepsUntilFault(rig, 200, &at_fault), 0);
  EXPECT_EQ(at_fault.fault, SafetyFault::kHeartbeatLost);
  EXPECT_TRUE(IsZeroOutput(rig, at_fault));
  // The fault period's time is now_s − one period (Step advanced the clock).
  const double detected_after_s = rig.now_s() - kPeriod_s - last_heartbeat_s;
  EXPECT_GE(detected_after_s, options.cycle.safety.heartbeat_timeout_s - 1e-9);
  EXPECT_LE(detected_after_s, options.cycle.safety.heartbeat_timeout_s + kPeriod_s + 1e-9);
  ExpectEmcyAtDevice(rig, EmcyCode::kHeartbeatLost);
  rig.device().set_faults({});
  ExpectRecoversWithoutRearm(rig);
}

TEST(Safety, LongHeartbeatSilenceIsAHardFault) {
  SimulatedRig rig(HoldingHand(ControlMode::kFree));
  ASSERT_TRUE(rig.BringUp());
  rig.device().set_faults({.mute_heartbeat = true});
  for (int i = 0; i < 200; ++i) rig.Step();
  EXPECT_EQ(rig.cycle().output().fault, SafetyFault::kCommunicationLost);
  rig.device().set_faults({});
  ExpectOnlyRearmLeavesSafeState(rig, SafetyFault::kCommunicationLost);
}

// The station's process stops (kill -STOP / -CONT, a descheduled VM): the
// simulated device in it stops too, no SYNC goes out, so nothing is missing.
TEST(Safety, StallsOfTheWholeProcessAreNotSilence) {
  SimulatedRig rig(HoldingHand(ControlMode::kFree));
  ASSERT_TRUE(rig.BringUp());
  for (double stall_s : {0.020, 0.030, 0.050, 0.030, 0.200}) {
    for (int i = 0; i < 100; ++i) ASSERT_EQ(rig.Step().fault, SafetyFault::kNone);
    rig.StallAll(stall_s);
    for (int i = 0; i < 100; ++i) {
      const CycleOutput& output = rig.Step();
      ASSERT_EQ(output.fault, SafetyFault::kNone) << "after a stall of " << stall_s << " s";
      ASSERT_TRUE(output.command.powered);
    }
  }
  EXPECT_EQ(rig.cycle().safety().transient_faults(), 0u);
  EXPECT_EQ(rig.cycle().safety().stalls(), 5u);
}

// Only the station stalls; the device (its own hardware) runs on, misses the
// station's heartbeat after 25 ms, cuts its motors and says so (EMCY). That is
// a transient fault: the station restarts it (NMT start) and fades back in.
TEST(Safety, AStationStallThatMakesTheDeviceCutItsMotorsIsTransient) {
  SimulatedRig rig(HoldingHand(ControlMode::kFree));
  ASSERT_TRUE(rig.BringUp());
  for (double stall_s : {0.030, 0.040, 0.050, 0.030, 0.045}) {
    for (int i = 0; i < 20; ++i) rig.Step();
    rig.StallStation(stall_s);
    ASSERT_TRUE(rig.device().host_heartbeat_lost());
    CycleOutput at_fault;
    ASSERT_GT(StepsUntilFault(rig, 10, &at_fault), 0);
    EXPECT_EQ(at_fault.fault, SafetyFault::kDeviceMissedHeartbeat);
    EXPECT_TRUE(IsZeroOutput(rig, at_fault));
    ExpectRecoversWithoutRearm(rig);
    EXPECT_FALSE(rig.device().host_heartbeat_lost());
    EXPECT_EQ(rig.device().nmt_state(), NmtState::kOperational);
    EXPECT_NE(rig.device().applied_voltages(), MotorVoltages{});
  }
  EXPECT_EQ(rig.cycle().safety().transient_faults(), 5u);
  EXPECT_EQ(rig.cycle().safety().hard_faults(), 0u);
}

// A stall shorter than the device's heartbeat timeout costs nothing.
TEST(Safety, AShortStationStallIsNoFault) {
  SimulatedRig rig(HoldingHand(ControlMode::kFree));
  ASSERT_TRUE(rig.BringUp());
  for (int i = 0; i < 3; ++i) rig.Step();  // just after a heartbeat of the station
  rig.StallStation(0.012);
  for (int i = 0; i < 50; ++i) ASSERT_EQ(rig.Step().fault, SafetyFault::kNone);
}

TEST(Safety, ADeviceThatStaysWithoutMotorsBecomesAHardFault) {
  SimulatedRig rig(HoldingHand(ControlMode::kFree));
  ASSERT_TRUE(rig.BringUp());
  rig.StallStation(0.030);
  // Its NMT start never arrives: the device sends EMCY heartbeat-lost again
  // and again as if it could not restart (its PDOs say motors off).
  Emcy lost;
  lost.node_id = kDeviceNodeId;
  lost.code = EmcyCode::kHeartbeatLost;
  for (int i = 0; i < 200; ++i) {
    rig.device().SendRawFrame(EncodeEmcy(lost));
    rig.Step();
  }
  EXPECT_EQ(rig.cycle().output().fault, SafetyFault::kCommunicationLost);
  EXPECT_EQ(rig.cycle().safety().hard_faults(), 1u);
}

TEST(Safety, BusOffErrorFrameGivesZeroOutputInTheSamePeriod) {
  SimulatedRig rig(HoldingHand(ControlMode::kFree));
  ASSERT_TRUE(rig.BringUp());
  for (int i = 0; i < 10; ++i) rig.Step();
  rig.device().SendBusError({.bus_off = true});
  CycleOutput at_fault;
  EXPECT_EQ(StepsUntilFault(rig, 10, &at_fault), 1);
  EXPECT_EQ(at_fault.fault, SafetyFault::kBusOff);
  EXPECT_TRUE(IsZeroOutput(rig, at_fault));
  ExpectEmcyAtDevice(rig, EmcyCode::kCanBusOff);
  ExpectOnlyRearmLeavesSafeState(rig, SafetyFault::kBusOff);
}

// Issue #20: no test tripped the safe state when the CAN transport itself
// fails. The device's end of the bus goes away (a USB adapter unplugged, the
// socket shut): the next read sees the link down and the output is zero in
// that period, until an explicit re-arm once the link is back.
TEST(Safety, TheTransportFailingGivesZeroOutputInTheSamePeriod) {
  SimulatedRig rig(HoldingHand(ControlMode::kFree));
  ASSERT_TRUE(rig.BringUp());
  for (int i = 0; i < 20; ++i) ASSERT_EQ(rig.Step().fault, SafetyFault::kNone);
  ASSERT_EQ(::shutdown(rig.device().bus_fd(), SHUT_RDWR), 0);
  CycleOutput at_fault;
  EXPECT_EQ(StepsUntilFault(rig, 10, &at_fault), 1);
  EXPECT_EQ(at_fault.fault, SafetyFault::kLinkDown);
  EXPECT_TRUE(IsZeroOutput(rig, at_fault));
  for (int i = 0; i < kPeriodsAfterFaultCleared; ++i) {
    const CycleOutput& output = rig.Step();
    ASSERT_NE(output.fault, SafetyFault::kNone) << "left the safe state after " << i;
    ASSERT_TRUE(IsZeroOutput(rig, output));
  }
}

TEST(Safety, ErrorPassiveErrorFrameGivesZeroOutputInTheSamePeriod) {
  SimulatedRig rig(HoldingHand(ControlMode::kFree));
  ASSERT_TRUE(rig.BringUp());
  rig.device().SendBusError({.error_passive = true});
  CycleOutput at_fault;
  EXPECT_EQ(StepsUntilFault(rig, 10, &at_fault), 1);
  EXPECT_EQ(at_fault.fault, SafetyFault::kErrorPassive);
  EXPECT_TRUE(IsZeroOutput(rig, at_fault));
  ExpectOnlyRearmLeavesSafeState(rig, SafetyFault::kErrorPassive);
}

TEST(Safety, ErrorWarningAloneIsCountedButNotAFault) {
  SimulatedRig rig(HoldingHand(ControlMode::kFree));
  ASSERT_TRUE(rig.BringUp());
  rig.device().SendBusError({.error_warning = true});
  for (int i = 0; i < 10; ++i) EXPECT_EQ(rig.Step().fault, SafetyFault::kNone);
  EXPECT_EQ(rig.driver().counters().bus_errors, 1u);
}

TEST(Safety, DeviceEmcyGivesZeroOutputInTheSamePeriod) {
  SimulatedRig rig(HoldingHand(ControlMode::kFree));
  ASSERT_TRUE(rig.BringUp());
  Emcy overcurrent;
  overcurrent.node_id = kDeviceNodeId;
  overcurrent.code = EmcyCode::kCurrentExceeded;
  rig.device().SendRawFrame(EncodeEmcy(overcurrent));
  CycleOutput at_fault;
  EXPECT_EQ(StepsUntilFault(rig, 10, &at_fault), 1);
  EXPECT_EQ(at_fault.fault, SafetyFault::kDeviceEmergency);
  EXPECT_TRUE(IsZeroOutput(rig, at_fault));
  ExpectOnlyRearmLeavesSafeState(rig, SafetyFault::kDeviceEmergency);
}

TEST(Safety, StalledModelGivesZeroOutputAfterTwoPeriods) {
  testing::ScriptedSource source;
  SimulatedRig rig(HoldingHand(ControlMode::kCoupled), &source);
  ASSERT_TRUE(rig.BringUp());
  for (int i = 0; i < 20; ++i) rig.Step();
  source.stalled = true;
  CycleOutput at_fault;
  // Period 1 without an update is tolerated; period 2 is the fault.
  EXPECT_EQ(StepsUntilFault(rig, 10, &at_fault), 2);
  EXPECT_EQ(at_fault.fault, SafetyFault::kModelStalled);
  EXPECT_TRUE(IsZeroOutput(rig, at_fault));
  ExpectEmcyAtDevice(rig, EmcyCode::kModelStalled);
  source.stalled = false;
  ExpectOnlyRearmLeavesSafeState(rig, SafetyFault::kModelStalled);
}

TEST(Safety, NanFromTheModelGivesZeroOutputInTheSamePeriod) {
  testing::ScriptedSource source;
  SimulatedRig rig(HoldingHand(ControlMode::kCoupled), &source);
  ASSERT_TRUE(rig.BringUp());
  for (int i = 0; i < 20; ++i) rig.Step();
  source.poison = true;
  CycleOutput at_fault;
  EXPECT_EQ(StepsUntilFault(rig, 10, &at_fault), 1);
  EXPECT_EQ(at_fault.fault, SafetyFault::kNonFinite);
  EXPECT_TRUE(IsZeroOutput(rig, at_fault));
  ExpectEmcyAtDevice(rig, EmcyCode::kSoftwareNonFinite);
  source.poison = false;
  ExpectOnlyRearmLeavesSafeState(rig, SafetyFault::kNonFinite);
}

// A device whose force sensor reads NaN; every other reading is fresh and
// healthy.
class NanForceSensorDevice final : public HapticDevice {
 public:
  void Read(double now_s, DeviceState* state) override {
    state->force_N = std::numeric_limits<double>::quiet_NaN();
    state->last_encoder_time_s = now_s;
    state->last_sensor_time_s = now_s;
    state->last_heartbeat_time_s = now_s;
    state->device_nmt_state = NmtState::kOperational;
    state->motors_enabled = true;
  }
  void Write(double, const MotorCommand& command) override { written.push_back(command); }
  void SendEmergency(double, EmcyCode code) override { emergencies.push_back(code); }
  void Enable(double) override {}
  void ClearFaultFlags(DeviceState*) override {}
  DeviceCounters counters() const override { return {}; }
  std::vector<MotorCommand> written;
  std::vector<EmcyCode> emergencies;
};

TEST(Safety, NanFromTheForceSensorTripsInItsPeriodAndNeverReachesTheModel) {
  NanForceSensorDevice device;
  testing::ScriptedSource source;
  CycleOptions options;
  options.control.mode = ControlMode::kCoupled;
  HapticCycle cycle(&device, &source, options);
  cycle.Rearm();
  const CycleOutput& output = cycle.Run(0.0);
  EXPECT_EQ(output.fault, SafetyFault::kNonFinite);
  EXPECT_EQ(source.updates(), 0u);  // the model never saw the reading
  ASSERT_EQ(device.written.size(), 1u);
  EXPECT_FALSE(device.written[0].powered);
  ASSERT_EQ(device.emergencies.size(), 1u);
  EXPECT_EQ(device.emergencies[0], EmcyCode::kSoftwareNonFinite);
}

TEST(Safety, InfiniteCommandIsZeroedAndTrips) {
  // A spring gain of +inf makes the spring law itself produce ±inf/NaN.
  auto options = HoldingHand(ControlMode::kSpring);
  options.cycle.control.spring_gain_ratio = std::numeric_limits<double>::infinity();
  SimulatedRig rig(options);
  ASSERT_TRUE(rig.BringUp());
  CycleOutput at_fault;
  EXPECT_EQ(StepsUntilFault(rig, 10, &at_fault), 1);
  EXPECT_EQ(at_fault.fault, SafetyFault::kNonFinite);
  EXPECT_TRUE(IsZeroOutput(rig, at_fault));
}

TEST(Safety, OutputIsAlwaysClampedToTheDeviceLimits) {
  // A very stiff spring and a hand 50 mm away ask for far more than 10 N.
  auto options = HoldingHand(ControlMode::kSpring);
  options.device.hand.thrust = {HandDrive::kPosition, 0.05, 0.0, 0.0, 0.0, 0.0};
  options.device.hand.roll = {HandDrive::kPosition, 1.0, 0.0, 0.0, 0.0, 0.0};
  options.cycle.control.spring_stiffness_N_per_m = 2000.0;
  options.cycle.control.spring_stiffness_Nm_per_rad = 5.0;
  SimulatedRig rig(options);
  ASSERT_TRUE(rig.BringUp());
  double max_force_N = 0.0;
  double max_torque_Nm = 0.0;
  for (int i = 0; i < 500; ++i) {
    const CycleOutput& output = rig.Step();
    max_force_N = std::max(max_force_N, std::abs(output.command.thrust_force_N));
    max_torque_Nm = std::max(max_torque_Nm, std::abs(output.command.roll_torque_Nm));
  }
  EXPECT_LE(max_force_N, options.cycle.limits.max_force_N);
  EXPECT_LE(max_torque_Nm, options.cycle.limits.max_torque_Nm);
  EXPECT_EQ(max_force_N, options.cycle.limits.max_force_N);  // it did saturate
}

TEST(ClampCommand, ClampsAndZeroesNonFiniteValues) {
  const OutputLimits limits{10.0, 0.3};
  bool non_finite = false;
  MotorCommand big{25.0, -1.0, true};
  const MotorCommand clamped = ClampCommand(big, limits, &non_finite);
  EXPECT_EQ(clamped.thrust_force_N, 10.0);
  EXPECT_EQ(clamped.roll_torque_Nm, -0.3);
  EXPECT_FALSE(non_finite);
  MotorCommand bad{std::nan(""), 0.1, true};
  EXPECT_EQ(ClampCommand(bad, limits, &non_finite).thrust_force_N, 0.0);
  EXPECT_TRUE(non_finite);
}

TEST(SafetyMonitor, RejectsInvalidLimits) {
  EXPECT_THROW(SafetyMonitor({.sensor_timeout_s = 0.0}), std::invalid_argument);
  EXPECT_THROW(SafetyMonitor({.model_stall_periods = 0}), std::invalid_argument);
  EXPECT_THROW(SafetyMonitor({.hard_after_s = 0.01, .healthy_before_fade_s = 0.05}),
               std::invalid_argument);
}

TEST(SafetyMonitor, EveryFaultIsEitherTransientOrNeedsARearm) {
  EXPECT_TRUE(IsTransient(SafetyFault::kSensorTimeout));
  EXPECT_TRUE(IsTransient(SafetyFault::kHeartbeatLost));
  EXPECT_TRUE(IsTransient(SafetyFault::kDeviceMissedHeartbeat));
  for (SafetyFault hard : {SafetyFault::kNotArmed, SafetyFault::kCommunicationLost,
                           SafetyFault::kBusOff, SafetyFault::kErrorPassive, SafetyFault::kLinkDown,
                           SafetyFault::kNonFinite, SafetyFault::kModelStalled,
                           SafetyFault::kDeviceEmergency}) {
    EXPECT_FALSE(IsTransient(hard)) << ToString(hard);
  }
}

}  // namespace
}  // namespace ves::haptics
