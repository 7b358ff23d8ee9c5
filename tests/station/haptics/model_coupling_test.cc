// The coupled mode with the real endoscope-colon model in the loop
// (ModelBaseResponse): a short, rigid, closed tube is a wall at its end,
// felt through the virtual coupling spring k_c.
#include <gtest/gtest.h>

#include <iostream>
#include <vector>

#include "station/haptics/model_base_response.h"
#include "station/haptics/sim_rig.h"
#include "station/model/model.h"

namespace ves::haptics {
namespace {

constexpr double kTubeLength_m = 0.06;

model::ModelParams ShortClosedTube() {
  model::TissueParams tissue;  // a wall that does not move, little friction
  tissue.suspension_stiffness_N_per_m2 = 1.0e6;
  tissue.suspension_damping_N_s_per_m2 = 1.0e3;
  tissue.wall_stiffness_N_per_m = 5000.0;
  tissue.wall_damping_N_s_per_m = 0.5;
  tissue.deformation_threshold_m = 0.05;
  tissue.static_friction = 0.05;
  tissue.dynamic_friction = 0.05;
  tissue.neighbor_tension_N = 1.0;
  std::vector<Eigen::Vector3d> points;
  for (int i = 0; i <= 12; ++i) points.emplace_back(0.0, 0.0, i * kTubeLength_m / 12);
  model::ModelParams params;
  params.colon = model::MakeColonFromPoints(points, 0.0085, tissue);
  params.gravity_W_m_per_s2.setZero();
  params.dt_s = 0.001;
  params.thrust_damping_N_s_per_m = 5.0;  // the free scope's drag: 0.5 N at 100 mm/s
  return params;
}

SimulatedRigOptions PushingHand() {
  // Force-driven hand: F = 2 N · sin(2π · 0.25 Hz · t), 2 N at t = 1 s.
  SimulatedRigOptions options;
  options.device.hand.thrust = {HandDrive::kForce, 0.0, 2.0, 0.25, 0.0, 0.0};
  options.device.hand.roll = {HandDrive::kForce, 0.0, 0.0, 0.0, 0.0, 0.0};
  options.cycle.control.mode = ControlMode::kCoupled;
  return options;
}

TEST(ModelCoupling, PushingIntoTheClosedEndOfATubeFeelsAWall) {
  constexpr double kCoupling_N_per_m = 300.0;
  ModelBaseResponse model(ShortClosedTube(), 0.0, kCoupling_N_per_m);
  SimulatedRig rig(PushingHand(), &model);
  ASSERT_TRUE(rig.BringUp());
  double reaction_sum_N = 0.0;
  int reaction_count = 0;
  while (rig.device().plant().t_s < 1.0) {
    const CycleOutput& output = rig.Step();
    ASSERT_EQ(output.fault, SafetyFault::kNone) << "at t=" << rig.now_s();
    if (rig.device().plant().t_s > 0.9) {
      reaction_sum_N += -output.base.thrust_force_N;
      ++reaction_count;
    }
  }
  const double insertion_m = rig.cycle().device_state().insertion_m;
  const double mean_reaction_N = reaction_sum_N / reaction_count;
  std::cout << "model wall: insertion_mm=" << insertion_m * 1e3
            << " model_tip_arc_mm=" << model.state().tip_arc_m * 1e3
            << " mean_reaction_N=" << mean_reaction_N
            << " hand_force_N=" << rig.cycle().device_state().force_N << "\n";
  // The tip stops at the tube's closed end (a free scope went > 400 mm in
  // coupled_mode_test); the device stands F/k_c beyond it:
  // 60 mm + 2 N / 300 N/m = 66.7 mm. The hand's 2 N is balanced by the model
  // (averaged over the last 100 ms: the model's contact chatters at the end).
  EXPECT_NEAR(model.state().tip_arc_m, kTubeLength_m, 0.005);
  EXPECT_NEAR(insertion_m, kTubeLength_m + 2.0 / kCoupling_N_per_m, 0.005);
  EXPECT_NEAR(mean_reaction_N, 2.0, 0.3);
}

TEST(ModelCoupling, NonFiniteModelStateTripsTheSafeState) {
  // A NaN insertion offset poisons the model's input: its output is not
  // finite and the adapter reports NaN, which must reach the safety monitor.
  ModelBaseResponse model(ShortClosedTube(), std::numeric_limits<double>::quiet_NaN());
  EXPECT_THROW(ModelBaseResponse(ShortClosedTube(), 0.0, 0.0), std::invalid_argument);
  SimulatedRig rig(PushingHand(), &model);
  rig.BringUp();
  EXPECT_EQ(rig.Step().fault, SafetyFault::kNonFinite);
}

}  // namespace
}  // namespace ves::haptics
