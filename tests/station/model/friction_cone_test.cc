// The friction cone (paper Fig. 9, eqs. 16-17): a contact holds below mu_s*N
// and slides above it, resisting with mu_d*N while it slides.
#include <gtest/gtest.h>

#include "tests/station/model/model_test_util.h"

namespace ves::model {
namespace {

using testing::MakeStraightTube;
using testing::RigidTissue;
using testing::Sim;

constexpr double kMuS = 0.4;
constexpr double kMuD = 0.25;

// A scope lying on the floor of a straight horizontal tube under gravity: the
// floor carries its weight as the normal force N.
ModelParams FloorParams() {
  ModelParams params;
  params.scope.link_count = 30;
  params.colon = MakeStraightTube(1.6, 0.01, 0.0075, RigidTissue(kMuS, kMuD));
  params.scope.linear_mass_kg_per_m = 2.0;  // heavy, so N is well above noise
  return params;
}

double TotalNormalForce_N(const StepOutput& out) {
  double sum = 0.0;
  for (int i = 0; i < out.contact_count; ++i) sum += out.contacts[i].normal_force_N;
  return sum;
}

// Inserts to 0.5 m and lets it settle; returns N.
double Settle(Sim* sim) {
  EXPECT_TRUE(sim->RunUntil(1.0, [](const Sim& s) {
    StepInput in;
    in.insertion_m = std::min(0.5, 1.0 * (s.state.time_s + s.params.dt_s));
    return in;
  }));
  EXPECT_TRUE(sim->RunUntil(1.5, [](const Sim&) {
    StepInput in;
    in.insertion_m = 0.5;
    return in;
  }));
  return TotalNormalForce_N(sim->out);
}

TEST(FrictionCone, HoldsBelowStaticLimit) {
  Sim sim(FloorParams());
  const double N = Settle(&sim);
  ASSERT_GT(N, 1.0);
  const double start_m = sim.state.inserted_m;
  const double push_N = 0.8 * kMuS * N;
  ASSERT_TRUE(sim.RunUntil(3.0, [&](const Sim&) {
    StepInput in;
    in.thrust_mode = ThrustMode::kForce;
    in.push_force_N = push_N;
    return in;
  }));
  // Stuck: only the stick springs' elastic give, mu_s N / (k_t * contacts), moves it.
  EXPECT_LT(sim.state.inserted_m - start_m, 1e-3);
  EXPECT_LT(sim.out.velocity_norm_m_per_s, 1e-4);
  EXPECT_NEAR(sim.out.base_force_N, push_N, 0.02 * push_N);  // the floor holds it all
}

TEST(FrictionCone, SlidesAboveStaticLimitWithDynamicFriction) {
  Sim sim(FloorParams());
  const double N = Settle(&sim);
  const double start_m = sim.state.inserted_m;
  const double push_N = 1.3 * kMuS * N;
  double force_sum_N = 0.0;
  double normal_sum_N = 0.0;
  int count = 0;
  ASSERT_TRUE(sim.RunUntil(2.5, [&](const Sim& s) {
    if (s.state.time_s > 2.0) {
      force_sum_N += s.out.base_force_N;
      normal_sum_N += TotalNormalForce_N(s.out);
      ++count;
    }
    StepInput in;
    in.thrust_mode = ThrustMode::kForce;
    in.push_force_N = push_N;
    return in;
  }));
  EXPECT_GT(sim.state.inserted_m - start_m, 0.02);  // it slides
  // While sliding the floor resists with mu_d N (eq. 17 with alpha = 1).
  const double resistance_N = force_sum_N / count;
  const double expected_N = kMuD * normal_sum_N / count;
  EXPECT_NEAR(resistance_N, expected_N, 0.05 * expected_N);
}

}  // namespace
}  // namespace ves::model
