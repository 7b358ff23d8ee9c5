// The keyboard's hand (haptics::KeyboardPush): its push ramps and is bounded
// to what a hand gives (docs/station-ui.md, "The keyboard hand").
#include "station/haptics/keyboard_push.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <stdexcept>

#include "station/haptics/ball_drive_plant.h"
#include "station/haptics/protocol.h"

namespace ves::haptics {
namespace {

constexpr double kPeriod_s = 0.001;
constexpr double kKeyStep_m = 0.005;     // one press of w (ui::KeyboardHand)
constexpr double kAutoRepeat_s = 1.0 / 30.0;  // X's key repeat while w is held

// The hand's axial force on a scope at `scope_m` moving at `velocity`.
double ForceOn(const HandProfile& hand, double scope_m, double velocity) {
  PlantState plant;
  plant.insertion_m = scope_m;
  plant.insertion_velocity_m_per_s = velocity;
  double force_N = 0.0;
  double torque_Nm = 0.0;
  CalcHandLoad(hand, plant, 0.0, &force_N, &torque_Nm);
  return force_N;
}

// Holding the push key for 20 s against a scope that does not move (the
// colon blocks it), and one the colon pushes back at 5 cm/s: the hand never
// pushes harder than the documented steady push, reaches it (the bound is
// not a weak hand), and gets there by a ramp, not a step.
TEST(KeyboardPush, HoldingThePushKeyFor20sNeverCommandsMoreThanTheSteadyPush) {
  for (const double scope_velocity : {0.0, -0.05}) {
    KeyboardPush push(KeyboardPushCurve{}, kPeriod_s);
    const double scope_m = 0.30;
    double target_m = scope_m;
    double next_key_s = 0.0;
    double peak_N = 0.0;
    double at_100ms_N = 0.0;
    for (int step = 0; step < 20'000; ++step) {
      const double t_s = step * kPeriod_s;
      if (t_s >= next_key_s) {  // the key repeats: the target runs ahead unbounded
        target_m += kKeyStep_m;
        next_key_s += kAutoRepeat_s;
      }
      const HandProfile hand = push.Next(target_m, 0.0, scope_m);
      const double force_N = ForceOn(hand, scope_m, scope_velocity);
      ASSERT_LE(force_N, push.curve().steady_N + 1e-9) << "at " << t_s << " s";
      ASSERT_LE(push.force_limit_N(), push.curve().steady_N);
      peak_N = std::max(peak_N, force_N);
      if (step == 100) at_100ms_N = force_N;
    }
    EXPECT_NEAR(peak_N, push.curve().steady_N, 1e-6) << "the hand never reached its steady push";
    EXPECT_LT(at_100ms_N, 0.5 * push.curve().steady_N) << "the push stepped instead of ramping";
    EXPECT_GT(at_100ms_N, push.curve().hold_N);
    // 20 s of key repeats put the target 3 m ahead; the hand's own position
    // stayed within its bound of the scope (no wind-up).
    const HandProfile last = push.Next(target_m, 0.0, scope_m);
    EXPECT_LE(last.thrust.offset - scope_m,
              push.curve().steady_N / last.thrust_stiffness_N_per_m + 1e-12);
  }
}

// Without the bound the same hold commands what the issue measured and
// more: the plant's clamp is what holds the force (a regression guard on
// HandProfile::thrust_force_limit_N).
TEST(KeyboardPush, TheBoundIsThePlantsClampOnThePositionHand) {
  HandProfile hand;
  hand.thrust.offset = 0.05;  // 5 cm ahead of a scope at 0
  EXPECT_NEAR(ForceOn(hand, 0.0, 0.0), 100.0, 1e-9);
  hand.thrust_force_limit_N = 10.0;
  EXPECT_DOUBLE_EQ(ForceOn(hand, 0.0, 0.0), 10.0);
  EXPECT_DOUBLE_EQ(ForceOn(hand, 0.10, 0.0), -10.0);  // pulling back is bounded too
  hand.thrust.drive = HandDrive::kForce;  // a scripted force is what it says
  hand.thrust.offset = 30.0;
  EXPECT_DOUBLE_EQ(ForceOn(hand, 0.0, 0.0), 30.0);
}

// In free space the bounded hand still moves the scope with the keys: the
// plant (no motor force) follows a held key to within a key step.
TEST(KeyboardPush, AFreeScopeFollowsAHeldKey) {
  KeyboardPush push(KeyboardPushCurve{}, kPeriod_s);
  const BallDriveParams params;
  PlantState plant;
  double target_m = 0.0;
  double next_key_s = 0.0;
  for (int step = 0; step < 2000; ++step) {
    const double t_s = step * kPeriod_s;
    if (t_s >= next_key_s && t_s < 1.0) {
      target_m += kKeyStep_m;
      next_key_s += kAutoRepeat_s;
    }
    const HandProfile hand = push.Next(target_m, 0.0, plant.insertion_m);
    StepBallDrive(params, hand, MotorVoltages{}, kPeriod_s, 20, &plant);
    ASSERT_LE(std::abs(plant.hand_force_N), push.curve().steady_N + 1e-9);
  }
  EXPECT_NEAR(target_m, 0.15, kKeyStep_m);
  EXPECT_NEAR(plant.insertion_m, target_m, kKeyStep_m);
}

// The key released and the scope caught up: the bound falls back to the
// grip within the ramp's time.
TEST(KeyboardPush, ReleasedTheBoundFallsBackToTheGrip) {
  KeyboardPush push(KeyboardPushCurve{}, kPeriod_s);
  for (int step = 0; step < 1000; ++step) push.Next(1.0, 0.0, 0.0);
  EXPECT_DOUBLE_EQ(push.force_limit_N(), push.curve().steady_N);
  for (int step = 0; step < 600; ++step) push.Next(0.0, 0.0, 0.0);
  EXPECT_DOUBLE_EQ(push.force_limit_N(), push.curve().hold_N);
}

TEST(KeyboardPush, ACurveAHandCannotGiveIsRefused) {
  EXPECT_THROW(KeyboardPush(KeyboardPushCurve{}, 0.0), std::invalid_argument);
  EXPECT_THROW(KeyboardPush(KeyboardPushCurve{.hold_N = 12.0, .steady_N = 10.0}, kPeriod_s),
               std::invalid_argument);
  EXPECT_THROW(KeyboardPush(KeyboardPushCurve{.ramp_N_per_s = 0.0}, kPeriod_s),
               std::invalid_argument);
}

}  // namespace
}  // namespace ves::haptics
