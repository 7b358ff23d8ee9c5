// Capstan law through a single bend: pushing the scope through a bend of angle
// theta against a load F_out at the tip needs F_in = F_out e^(mu theta) when
// the scope slides along the outer wall with friction mu. The load is large
// against the scope's bending stiffness (EI/R_b^2 ~ 5 N vs 20 N) and the
// straight parts are short enough not to buckle (pi^2 EI / 0.05^2 ~ 120 N).
#include <cmath>
#include <cstdio>

#include <gtest/gtest.h>

#include "tests/station/model/model_test_util.h"

namespace ves::model {
namespace {

using testing::MakeBendTube;
using testing::RigidTissue;
using testing::Sim;

constexpr double kMu = 0.2;
constexpr double kRelativeTolerance = 0.10;  // the 10 %

double MeasureForceRatio(double theta_rad) {
  const double entry_m = 0.05, bend_radius_m = 0.08, exit_m = 0.35;
  ModelParams params;
  params.colon = MakeBendTube(entry_m, theta_rad, bend_radius_m, exit_m, 0.005, 0.0085,
                              RigidTissue(kMu, kMu));
  params.gravity_W_m_per_s2.setZero();
  params.scope.link_count = 120;
  params.scope.link_growth_ratio = 1.0;
  params.scope.flexural_rigidity_N_m2 = 0.03;
  params.scope.bending_section_rigidity_N_m2 = 0.03;
  params.sample_spacing_m = 0.006;
  const double bend_end_arc_m = entry_m + theta_rad * bend_radius_m;
  const double F_out_N = 20.0;
  const Eigen::Vector3d exit_dir(0.0, std::sin(theta_rad), std::cos(theta_rad));
  Sim sim(params);
  // Fast until the tip is past the bend, then slow while measuring: a sliding
  // contact keeps its stick spring in the implicit step, which acts like a
  // tangential viscosity k_t*dt (docs/model.md), negligible at 20 mm/s.
  constexpr double kFast_m_per_s = 0.1;
  constexpr double kSlow_m_per_s = 0.02;
  double insertion_m = 0.0;
  double load_from_s = -1.0;
  double force_sum_N = 0.0;
  int count = 0;
  const bool ok = sim.RunUntil(bend_end_arc_m / kFast_m_per_s + 2.0, [&](const Sim& s) {
    StepInput in;
    const bool loaded = s.state.tip_arc_m > bend_end_arc_m + 0.04;
    insertion_m += (loaded ? kSlow_m_per_s : kFast_m_per_s) * s.params.dt_s;
    in.insertion_m = insertion_m;
    if (loaded) {
      if (load_from_s < 0.0) load_from_s = s.state.time_s;
      in.tip_force_W_N = -F_out_N * exit_dir;
      if (s.state.time_s > load_from_s + 0.5 && count < 1000) {
        force_sum_N += s.out.base_force_N;
        ++count;
      }
    }
    return in;
  });
  EXPECT_TRUE(ok);
  EXPECT_EQ(count, 1000);
  return force_sum_N / count / F_out_N;
}

class CapstanTest : public ::testing::TestWithParam<double> {};

TEST_P(CapstanTest, ForceRatioFollowsExponentialOfMuTheta) {
  const double theta = GetParam();
  const double ratio = MeasureForceRatio(theta);
  const double expected = std::exp(kMu * theta);
  std::printf("capstan theta %.3f: F_in/F_out %.3f, e^(mu theta) %.3f\n", theta, ratio, expected);
  EXPECT_NEAR(ratio, expected, kRelativeTolerance * expected) << "theta " << theta;
}

INSTANTIATE_TEST_SUITE_P(Bends, CapstanTest,
                         ::testing::Values(kPi / 4, kPi / 2, 3 * kPi / 4, kPi));

}  // namespace
}  // namespace ves::model
