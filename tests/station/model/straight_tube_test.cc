// Analytic limits of the model: a straight tube gives no reaction, and with no
// contact and no gravity the scope keeps its shape.
#include <gtest/gtest.h>

#include "tests/station/model/model_test_util.h"

namespace ves::model {
namespace {

using testing::MakeStraightTube;
using testing::Sim;

constexpr double kZeroForce_N = 1e-9;
constexpr double kNoDrift_m = 1e-12;

ModelParams StraightTubeParams() {
  ModelParams params;
  // Longer than the scope (working length 1.68 m), so the tip never leaves it.
  params.colon = MakeStraightTube(2.0, 0.01, 0.03, TissueParams{});
  params.gravity_W_m_per_s2.setZero();
  return params;
}

TEST(StraightTube, ZeroReactionAtAnyInsertionSpeed) {
  for (double speed_m_per_s : {0.01, 0.1, 1.0, 5.0}) {
    Sim sim(StraightTubeParams());
    double peak_force_N = 0.0;
    double peak_torque_N_m = 0.0;
    ASSERT_TRUE(sim.RunUntil(0.2, [&](const Sim& s) {
      StepInput in;
      in.insertion_m = speed_m_per_s * (s.state.time_s + s.params.dt_s);
      return in;
    }));
    // Keep going and check along the way.
    for (int i = 0; i < 200; ++i) {
      StepInput in;
      in.insertion_m = speed_m_per_s * (sim.state.time_s + sim.params.dt_s);
      sim.StepOnce(in);
      peak_force_N = std::max(peak_force_N, std::abs(sim.out.base_force_N));
      peak_torque_N_m = std::max(peak_torque_N_m, std::abs(sim.out.roll_torque_Nm));
      EXPECT_EQ(sim.out.contact_count, 0);
    }
    EXPECT_LT(peak_force_N, kZeroForce_N) << "speed " << speed_m_per_s;
    EXPECT_LT(peak_torque_N_m, kZeroForce_N) << "speed " << speed_m_per_s;
    EXPECT_GT(sim.state.inserted_m, 0.0);
    // The tip stays on the axis and advances by exactly the insertion.
    EXPECT_NEAR(sim.state.X_WTip.translation().z(), sim.state.inserted_m, 1e-9);
    EXPECT_NEAR(sim.state.tip_arc_m, sim.state.inserted_m, 1e-9);
  }
}

TEST(StraightTube, NoContactNoGravityKeepsShape) {
  ModelParams params = StraightTubeParams();
  params.colon = MakeStraightTube(1.6, 0.01, 0.15, TissueParams{});  // wide: no contact
  Sim sim(params);
  StepInput in;
  in.insertion_m = 0.5;
  in.knob_up_rad = 1.0;
  in.knob_right_rad = -0.5;
  ASSERT_TRUE(sim.RunUntil(2.0, [&](const Sim&) { return in; }));  // settle on the knobs
  const ModelState settled = sim.state;
  ASSERT_TRUE(sim.RunUntil(4.0, [&](const Sim&) { return in; }));
  EXPECT_EQ(sim.out.contact_count, 0);
  for (size_t i = 0; i < settled.p_WSample.size(); ++i) {
    EXPECT_LT((sim.state.p_WSample[i] - settled.p_WSample[i]).norm(), kNoDrift_m) << i;
  }
  EXPECT_LT(sim.out.velocity_norm_m_per_s, 1e-9);
}

TEST(StraightTube, KnobUpBendsTipTowardItsImageUp) {
  ModelParams params = StraightTubeParams();
  params.colon = MakeStraightTube(1.6, 0.01, 0.15, TissueParams{});
  Sim sim(params);
  StepInput in;
  in.insertion_m = 0.5;
  in.knob_up_rad = kPi / 2;
  ASSERT_TRUE(sim.RunUntil(2.0, [&](const Sim&) { return in; }));
  // Up = the tip frame's +y at roll 0 is anterior (+y in W): the tip turns up.
  const Eigen::Vector3d view = sim.state.X_WTip.linear().col(2);
  EXPECT_GT(view.y(), 0.9);
  EXPECT_NEAR(view.x(), 0.0, 1e-9);
}

}  // namespace
}  // namespace ves::model
