// SessionModelSource: the training session as the coupled mode's model
// (station/app/haptic_session.h), without a device: the encoder readings are
// handed in directly, as HapticCycle::Run does each period.
#include "station/app/haptic_session.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <vector>

#include "station/haptics/haptic_cycle.h"
#include "station/training/replay.h"

namespace ves::station {
namespace {

constexpr double kLogForceTolerance_N = training::kLogForceResolution_N;
constexpr double kLogLengthTolerance_m = training::kLogLengthResolution_m;
constexpr double kLogAngleTolerance_rad = training::kLogAngleResolution_rad;

// A straight 0.4 m tube: small enough that a few hundred steps take milliseconds.
model::ModelParams TubeParams() {
  std::vector<Eigen::Vector3d> points;
  for (int i = 0; i <= 40; ++i) points.emplace_back(0.0, 0.0, 0.01 * i);
  model::ModelParams params;
  params.colon = model::MakeColonFromPoints(points, 0.02, model::TissueParams{});
  return params;
}

training::SessionConfig Config(const model::ModelParams& params) {
  training::SessionConfig config;
  config.case_id = "tube";
  config.dt_s = params.dt_s;
  config.time_limit_s = 10.0;
  config.thresholds = training::ThresholdsFor(params);
  return config;
}

class SessionModelSourceTest : public ::testing::Test {
 protected:
  SessionModelSourceTest() : params_(TubeParams()), runner_(params_, Config(params_)) {}

  model::ModelParams params_;
  training::SessionRunner runner_;
  haptics::SeqLock<ModelControls> controls_;
  SessionModelSource source_{&runner_, &controls_};
};

TEST_F(SessionModelSourceTest, WithoutARunningSessionItRendersNothingButStaysAlive) {
  const haptics::BaseResponse first = source_.Update(0.05, 0.2, params_.dt_s);
  const haptics::BaseResponse second = source_.Update(0.05, 0.2, params_.dt_s);
  EXPECT_EQ(first.thrust_force_N, 0.0);
  EXPECT_EQ(first.roll_torque_Nm, 0.0);
  // The count advances, so the safety monitor does not call the model stalled.
  EXPECT_EQ(second.update_count, first.update_count + 1);
  EXPECT_FALSE(source_.stepped());
  EXPECT_EQ(runner_.session().steps(), 0u);
}

TEST_F(SessionModelSourceTest, LogsTheCouplingForceItPushedTheModelWithAndRendersItsNegative) {
  const double model_start_m = runner_.state().inserted_m;
  const double model_roll_rad = runner_.state().roll_rad;
  controls_.Store(ModelControls{0.3, -0.2, training::ViewMode::kWireframe, true,
                                training::AbdominalPress::kMidAbdomen,
                                training::PatientPosition::kRightLateral});
  source_.Start(0, /*device_insertion_m=*/0.01, /*device_roll_rad=*/0.0);
  // The device moved 10 mm past where the session started: the coupling,
  // k_c·(x_device + offset − x_model) = 300 N/m × 0.010 m = 3.0 N, pushes the
  // model in; the hand is pulled back by the same 3.0 N.
  const haptics::BaseResponse response = source_.Update(0.02, 0.1, params_.dt_s);
  ASSERT_TRUE(source_.stepped());
  ASSERT_EQ(runner_.session().steps(), 1u);
  const training::InputSample& logged = runner_.session().inputs().back();
  EXPECT_EQ(logged.thrust_mode, training::ThrustMode::kForce);
  EXPECT_NEAR(logged.push_force_N, 3.0, kLogForceTolerance_N);
  EXPECT_NEAR(logged.insertion_m, model_start_m + 0.01, kLogLengthTolerance_m);
  EXPECT_NEAR(logged.roll_rad, model_roll_rad + 0.1, kLogAngleTolerance_rad);
  EXPECT_NEAR(logged.knob_up_rad, 0.3, kLogAngleTolerance_rad);
  EXPECT_NEAR(logged.knob_right_rad, -0.2, kLogAngleTolerance_rad);
  EXPECT_EQ(logged.view_mode, training::ViewMode::kWireframe);
  EXPECT_TRUE(logged.fluoroscopy_on);
  EXPECT_EQ(logged.abdominal_press, training::AbdominalPress::kMidAbdomen);
  EXPECT_EQ(logged.patient_position, training::PatientPosition::kRightLateral);
  EXPECT_EQ(response.thrust_force_N, -logged.push_force_N);
  EXPECT_EQ(response.roll_torque_Nm, -runner_.output().roll_torque_Nm);
  EXPECT_NEAR(source_.encoder_travel_m(), 0.0, 1e-12);  // one reading: no travel yet
}

// A device whose insertion encoder reads NaN; every other reading is fresh
// and healthy.
class NanEncoderDevice final : public haptics::HapticDevice {
 public:
  void Read(double now_s, haptics::DeviceState* state) override {
    state->insertion_m = std::nan("");
    state->last_encoder_time_s = now_s;
    state->last_sensor_time_s = now_s;
    state->last_heartbeat_time_s = now_s;
    state->device_nmt_state = haptics::NmtState::kOperational;
    state->motors_enabled = true;
  }
  void Write(double, const haptics::MotorCommand& command) override { written = command; }
  void SendEmergency(double, haptics::EmcyCode) override {}
  void Enable(double) override {}
  void ClearFaultFlags(haptics::DeviceState*) override {}
  haptics::DeviceCounters counters() const override { return {}; }
  haptics::MotorCommand written{0.0, 0.0, true};
};

TEST_F(SessionModelSourceTest, ANonFiniteReadingTripsTheCycleAndNeverReachesTheSession) {
  source_.Start(0, 0.0, 0.0);
  NanEncoderDevice device;
  haptics::CycleOptions options;
  options.period_s = params_.dt_s;
  options.control.mode = haptics::ControlMode::kCoupled;
  haptics::HapticCycle cycle(&device, &source_, options);
  cycle.Rearm();
  const haptics::CycleOutput& output = cycle.Run(0.0);
  EXPECT_EQ(output.fault, haptics::SafetyFault::kNonFinite);
  EXPECT_FALSE(device.written.powered);
  EXPECT_FALSE(source_.stepped());
  EXPECT_EQ(runner_.session().steps(), 0u);
}

TEST_F(SessionModelSourceTest, TheLogAloneReplaysTheModelExactly) {
  source_.Start(0, 0.0, 0.0);
  // A hand moving the device 20 mm in and out while turning it.
  for (int i = 0; i < 400; ++i) {
    const double t_s = i * params_.dt_s;
    source_.Update(0.02 * std::sin(10.0 * t_s), 0.3 * t_s, params_.dt_s);
  }
  // Travel: 0.02·sin(10 t) over 0.4 s goes up to 0.02 m (t = 0.157 s), then
  // down to 0.02·sin(4) = −0.0151 m: 0.02 + 0.0351 = 0.0551 m.
  EXPECT_NEAR(source_.encoder_travel_m(), 0.0551, 1e-3);
  training::SessionRunner replay(params_, Config(params_));
  replay.Start(0);
  for (const training::InputSample& sample : runner_.session().inputs()) replay.Step(sample);
  EXPECT_EQ(replay.state().inserted_m, runner_.state().inserted_m);
  EXPECT_EQ(replay.state().roll_rad, runner_.state().roll_rad);
  EXPECT_EQ(replay.session().metrics(), runner_.session().metrics());
}

// Issue #48: the clock started when the window opened. An armed session
// starts at the first insertion past the anus: until the device has moved
// the scope kStartInsertion_m in from where it was armed, nothing is
// stepped, logged or rendered, however long the trainee waits, turns the
// scope or pulls it back.
TEST_F(SessionModelSourceTest, AnArmedSessionStartsAtTheFirstInsertionPastTheAnus) {
  std::int64_t clock_ms = 1000;
  std::vector<std::int64_t> starts;
  source_.set_clock([&] { return clock_ms; });
  source_.set_on_start([&](std::int64_t start_unix_ms) { starts.push_back(start_unix_ms); });
  const double armed_at_m = 0.30;  // wherever the hand holds the device
  const double model_start_m = runner_.state().inserted_m;
  source_.Arm(armed_at_m, 0.1);
  EXPECT_TRUE(source_.armed());
  EXPECT_EQ(runner_.session().state(), training::SessionState::kReady);
  const double just_short_m = SessionModelSource::kStartInsertion_m - 0.0002;
  for (int i = 0; i < 3000; ++i) {  // 3 s of waiting, turning, pulling back, almost pushing
    clock_ms += 1;
    const double insertion_m = armed_at_m + (i < 1500 ? -0.01 : just_short_m);
    const haptics::BaseResponse idle = source_.Update(insertion_m, 0.1 + 0.001 * i, params_.dt_s);
    ASSERT_EQ(idle.thrust_force_N, 0.0) << i;
    ASSERT_EQ(idle.roll_torque_Nm, 0.0) << i;
    ASSERT_FALSE(source_.stepped()) << i;
  }
  EXPECT_EQ(runner_.session().steps(), 0u);
  EXPECT_EQ(runner_.session().state(), training::SessionState::kReady);
  EXPECT_TRUE(starts.empty());
  // In past the anus: the session starts with this very reading, its clock at 0.
  clock_ms = 4321;
  source_.Update(armed_at_m + SessionModelSource::kStartInsertion_m + 0.0001, 0.1, params_.dt_s);
  EXPECT_FALSE(source_.armed());
  ASSERT_TRUE(source_.stepped());
  EXPECT_EQ(runner_.session().state(), training::SessionState::kRunning);
  EXPECT_EQ(starts, std::vector<std::int64_t>{4321});
  EXPECT_EQ(runner_.session().steps(), 1u);
  EXPECT_NEAR(runner_.state().time_s, params_.dt_s, 1e-12);
  // The log maps the device's armed reading onto the anus.
  EXPECT_NEAR(runner_.session().inputs().back().insertion_m,
              model_start_m + SessionModelSource::kStartInsertion_m + 0.0001,
              kLogLengthTolerance_m);
  for (int i = 0; i < 10; ++i) source_.Update(armed_at_m + 0.01, 0.1, params_.dt_s);
  EXPECT_EQ(runner_.session().steps(), 11u);
  EXPECT_EQ(starts.size(), 1u);
  // A session that is not ready cannot be armed.
  EXPECT_THROW(source_.Arm(armed_at_m, 0.0), std::logic_error);
}

TEST(MakeStationHealth, CarriesTheCountersTheFaultsAndTheLoopsTail) {
  haptics::DeviceCounters counters;
  counters.bus_errors = 3;
  counters.lost_frames = 5;
  counters.send_failures = 7;
  counters.malformed_frames = 11;
  haptics::SafetyMonitor safety;
  safety.Rearm();
  safety.Trip(haptics::SafetyFault::kBusOff);  // one safe-state entry
  haptics::LoopStats loop;
  for (int i = 0; i < 980; ++i) loop.cycle_end.Add(200'400);  // ns
  for (int i = 0; i < 20; ++i) loop.cycle_end.Add(1'500'000);
  loop.cycles = 1000;
  loop.overruns = 20;

  const ves::v1::StationHealth h = MakeStationHealth("can:can0", counters, safety, &loop, 0.001);
  EXPECT_EQ(h.device(), "can:can0");
  EXPECT_EQ(h.loop_cycles(), 1000u);
  EXPECT_EQ(h.loop_cycle_p99_us(), 1500.0);  // 2 % of the cycles ended 1.5 ms after the deadline
  EXPECT_EQ(h.loop_budget_us(), 1000.0);
  EXPECT_EQ(h.loop_overruns(), 20u);
  EXPECT_EQ(h.hard_faults(), 1u);
  EXPECT_EQ(h.transient_faults(), 0u);
  EXPECT_EQ(h.can_bus_errors(), 3u);
  EXPECT_EQ(h.can_lost_frames(), 5u);
  EXPECT_EQ(h.can_send_failures(), 7u);
  EXPECT_EQ(h.can_malformed_frames(), 11u);

  // 1 % in the tail: the p99 is still the bulk.
  haptics::LoopStats light;
  for (int i = 0; i < 990; ++i) light.cycle_end.Add(200'400);
  for (int i = 0; i < 10; ++i) light.cycle_end.Add(1'500'000);
  light.cycles = 1000;
  EXPECT_EQ(MakeStationHealth("sim", counters, safety, &light, 0.001).loop_cycle_p99_us(), 201.0);

  // Headless (simulated time): no loop timing, the counts still.
  const ves::v1::StationHealth headless = MakeStationHealth("sim", {}, safety, nullptr, 0.001);
  EXPECT_EQ(headless.loop_cycles(), 0u);
  EXPECT_EQ(headless.loop_cycle_p99_us(), 0.0);
  EXPECT_EQ(headless.hard_faults(), 1u);
  EXPECT_EQ(headless.can_bus_errors(), 0u);
}

TEST(HandForSample, ForceSamplesPushAndPositionSamplesGripTheScope) {
  training::InputSample push;
  push.thrust_mode = training::ThrustMode::kForce;
  push.push_force_N = 4.5;
  push.roll_rad = 0.25;
  const haptics::HandProfile pushing = HandForSample(push, 0.1);
  EXPECT_EQ(pushing.thrust.drive, haptics::HandDrive::kForce);
  EXPECT_EQ(pushing.thrust.offset, 4.5);
  EXPECT_EQ(pushing.roll.drive, haptics::HandDrive::kPosition);
  EXPECT_EQ(pushing.roll.offset, 0.25);

  training::InputSample hold;
  hold.thrust_mode = training::ThrustMode::kPosition;
  hold.insertion_m = 0.3;
  const haptics::HandProfile holding = HandForSample(hold, 0.1);
  EXPECT_EQ(holding.thrust.drive, haptics::HandDrive::kPosition);
  EXPECT_NEAR(holding.thrust.offset, 0.2, 1e-12);  // model 0.3 m is device 0.2 m
}

}  // namespace
}  // namespace ves::station
