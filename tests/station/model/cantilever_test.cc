// Gravity: a scope held straight at the anus sags like a clamped cantilever
// under its own weight.
#include <gtest/gtest.h>

#include "tests/station/model/model_test_util.h"

namespace ves::model {
namespace {

using testing::MakeStraightTube;
using testing::Sim;

constexpr double kRelativeTolerance = 0.10;  // the 10 %

TEST(Cantilever, SettlesToSmallDeflectionShape) {
  // Equal links of 2.5 cm; inserting exactly 10 links puts a joint at the anus,
  // which clamps the free length L = 0.25 m (the guide holds the rest straight).
  ModelParams params;
  params.scope.working_length_m = 1.0;
  params.scope.link_count = 40;
  params.scope.link_growth_ratio = 1.0;
  params.scope.tip_link_length_m = 0.025;
  params.scope.bending_section_length_m = 0.0;
  params.scope.bending_section_rigidity_N_m2 = params.scope.flexural_rigidity_N_m2;
  params.scope.passive_section_length_m = 0.0;  // a uniform rod
  params.scope.joint_damping_N_m_s_per_rad = 0.002;
  params.colon = MakeStraightTube(1.2, 0.01, 0.15, TissueParams{});  // wide: no contact
  params.gravity_W_m_per_s2 = Eigen::Vector3d(0.0, -9.81, 0.0);
  const double L = 0.25;
  Sim sim(params);
  StepInput in;
  in.insertion_m = L;
  ASSERT_TRUE(sim.RunUntil(3.0, [&](const Sim&) { return in; }));
  EXPECT_EQ(sim.out.contact_count, 0);
  EXPECT_LT(sim.out.velocity_norm_m_per_s, 1e-6);  // settled
  // Small-deflection cantilever under a uniform load q = lambda g:
  //   w(L) = q L^4 / (8 EI) = 0.2*9.81 * 0.25^4 / (8 * 0.03) = 0.03193 m.
  const double q = params.scope.linear_mass_kg_per_m * 9.81;
  const double EI = params.scope.flexural_rigidity_N_m2;
  const double expected_m = q * L * L * L * L / (8.0 * EI);
  const double sag_m = -sim.state.X_WTip.translation().y();
  EXPECT_NEAR(sag_m, expected_m, kRelativeTolerance * expected_m);
  // And the slope at the tip, q L^3 / (6 EI).
  const double slope = -sim.state.X_WTip.linear().col(2).y();
  const double expected_slope = q * L * L * L / (6.0 * EI);
  EXPECT_NEAR(slope, expected_slope, kRelativeTolerance * expected_slope);
}

}  // namespace
}  // namespace ves::model
