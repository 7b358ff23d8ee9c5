// The coupled mode renders the model's base response to the hand. The model
// here is a synthetic source (a wall 10 mm in, 500 N/m): the hand pushing
// with a rising force must stop at the wall, where a free run goes far past.
#include <gtest/gtest.h>

#include <iostream>

#include "station/haptics/sim_rig.h"
#include "tests/station/haptics/scripted_source.h"

namespace ves::haptics {
namespace {

constexpr double kWall_m = 0.010;
constexpr double kWallStiffness_N_per_m = 500.0;
constexpr double kPositionTolerance_m = 0.001;

SimulatedRigOptions PushingHand(ControlMode mode) {
  // Force-driven hand: F = 2 N · sin(2π · 0.25 Hz · t), 2 N at t = 1 s.
  SimulatedRigOptions options;
  options.device.hand.thrust = {HandDrive::kForce, 0.0, 2.0, 0.25, 0.0, 0.0};
  options.device.hand.roll = {HandDrive::kForce, 0.0, 0.0, 0.0, 0.0, 0.0};
  options.cycle.control.mode = mode;
  return options;
}

double InsertionAfterOneSecond(SimulatedRig& rig) {
  if (!rig.BringUp()) return -1.0;
  while (rig.device().plant().t_s < 1.0) rig.Step();
  return rig.cycle().device_state().insertion_m;
}

TEST(CoupledMode, HandPushingIntoAModelWallFeelsTheWall) {
  testing::ScriptedSource wall;
  wall.wall_insertion_m = kWall_m;
  wall.wall_stiffness_N_per_m = kWallStiffness_N_per_m;
  SimulatedRig rig(PushingHand(ControlMode::kCoupled), &wall);
  const double insertion_m = InsertionAfterOneSecond(rig);
  // Quasi-static balance at the wall: F_hand = k_w·(x − x_w)
  // -> x = 10 mm + 2 N / 500 N/m = 14 mm.
  std::cout << "coupled wall: insertion_mm=" << insertion_m * 1e3
            << " force_N=" << rig.cycle().device_state().force_N << "\n";
  EXPECT_NEAR(insertion_m, kWall_m + 2.0 / kWallStiffness_N_per_m, kPositionTolerance_m);
  EXPECT_EQ(rig.cycle().output().fault, SafetyFault::kNone);
  EXPECT_NEAR(rig.cycle().output().base.thrust_force_N, -2.0, 0.2);
}

TEST(CoupledMode, WithoutTheWallTheSamePushGoesFarPastIt) {
  testing::ScriptedSource nothing;
  SimulatedRig rig(PushingHand(ControlMode::kCoupled), &nothing);
  const double insertion_m = InsertionAfterOneSecond(rig);
  std::cout << "coupled no wall: insertion_mm=" << insertion_m * 1e3 << "\n";
  EXPECT_GT(insertion_m, 5.0 * kWall_m);
}

TEST(CoupledMode, ConstructingWithoutASourceIsRejected) {
  SimulatedRigOptions options = PushingHand(ControlMode::kCoupled);
  EXPECT_THROW(SimulatedRig rig(options, nullptr), std::invalid_argument);
}

}  // namespace
}  // namespace ves::haptics
