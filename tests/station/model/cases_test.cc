// The model on the shipped cases (patient_db/cases): stability with the input
// held still, and the paper's Fig. 10 on paper-sigmoid.
#include <algorithm>
#include <cstdio>
#include <string>

#include <gtest/gtest.h>

#include "patient_db/case_format.h"
#include "station/training/case_model.h"
#include "tests/station/model/model_test_util.h"

namespace ves::model {
namespace {

using testing::Sim;

ModelParams LoadParams(const std::string& id, bool stiff_colon = false) {
  const auto colon_case =
      patient_db::LoadCaseFile(std::string(VES_SOURCE_DIR) + "/patient_db/cases/" + id + ".textproto");
  training::CaseModelOptions options;
  options.stiff_colon = stiff_colon;
  return training::MakeModelParams(colon_case, training::DefaultEndoscopeSpec(), options);
}

class SettleTest : public ::testing::TestWithParam<const char*> {};

// Insert 18 cm at 30 mm/s, then hold every input still: the state settles.
TEST_P(SettleTest, VelocityDecaysWithInputHeldStill) {
  Sim sim(LoadParams(GetParam()));
  ASSERT_TRUE(sim.RunUntil(6.0, [](const Sim& s) {
    StepInput in;
    in.insertion_m = 0.03 * (s.state.time_s + s.params.dt_s);
    return in;
  }));
  ASSERT_GT(sim.out.contact_count, 0);  // it is pressing on the wall
  const double moving = sim.out.velocity_norm_m_per_s;
  StepInput hold;
  hold.insertion_m = sim.state.inserted_m;
  ASSERT_TRUE(sim.RunUntil(7.0, [&](const Sim&) { return hold; }));
  const double after_1s = sim.out.velocity_norm_m_per_s;
  ASSERT_TRUE(sim.RunUntil(9.0, [&](const Sim&) { return hold; }));
  const double after_3s = sim.out.velocity_norm_m_per_s;
  EXPECT_LT(after_1s, 0.01 * moving);
  EXPECT_LT(after_3s, 1e-6);
}

INSTANTIATE_TEST_SUITE_P(ShippedCases, SettleTest,
                         ::testing::Values("paper-sigmoid", "standard-adult", "redundant-sigmoid",
                                           "fixed-tube"));

struct PushRun {
  double tip_arc_m{0.0};
  double inserted_m{0.0};
  double tip_advance_last_2s_m{0.0};
  double apex_lift_m{0.0};       // largest +y displacement of a sigmoid point
  double peak_stretch_m{0.0};
  std::vector<double> force_N;   // base force every second
  double largest_force_jump_N{0.0};  // between consecutive 10 ms samples
};

// The paper's run: constant push force at the base, no steering.
PushRun PushConstantForce(bool stiff_colon) {
  constexpr double kPush_N = 5.0;
  constexpr double kSeconds = 10.0;
  Sim sim(LoadParams("paper-sigmoid", stiff_colon));
  PushRun run;
  double tip_at_8s = 0.0;
  double last_force = 0.0;
  const auto push = [](const Sim&) {
    StepInput in;
    in.thrust_mode = ThrustMode::kForce;
    in.push_force_N = kPush_N;
    return in;
  };
  for (int ms10 = 1; ms10 <= kSeconds * 100; ++ms10) {
    EXPECT_TRUE(sim.RunUntil(ms10 * 0.01, push));
    if (ms10 > 1) {
      run.largest_force_jump_N =
          std::max(run.largest_force_jump_N, std::abs(sim.out.base_force_N - last_force));
    }
    last_force = sim.out.base_force_N;
    if (ms10 % 100 == 0) run.force_N.push_back(sim.out.base_force_N);
    if (ms10 == 800) tip_at_8s = sim.state.tip_arc_m;
  }
  run.tip_arc_m = sim.state.tip_arc_m;
  run.inserted_m = sim.state.inserted_m;
  run.tip_advance_last_2s_m = run.tip_arc_m - tip_at_8s;
  run.peak_stretch_m = sim.out.peak_stretch_m;
  for (size_t i = 0; i < sim.params.colon.points.size(); ++i) {
    if (sim.params.colon.points[i].region != Region::kSigmoid) continue;
    run.apex_lift_m = std::max(
        run.apex_lift_m, sim.state.p_WColon[i].y() - sim.params.colon.points[i].rest_position_m.y());
  }
  return run;
}

TEST(Fig10, ConstantPushStretchesSigmoidAndStallsWhileStiffColonGoesDeeper) {
  const PushRun soft = PushConstantForce(false);
  const double descending_start_m = 0.531;  // paper-sigmoid's regions
  // The tip stalls in the sigmoid, short of the descending colon...
  EXPECT_LT(soft.tip_arc_m, descending_start_m - 0.1);
  EXPECT_LT(soft.tip_advance_last_2s_m, 0.005);
  // ...while the hand has pushed several cm more scope in: the colon stretched.
  EXPECT_GT(soft.inserted_m - soft.tip_arc_m, 0.04);
  EXPECT_GT(soft.peak_stretch_m, 0.03);
  EXPECT_GT(soft.apex_lift_m, 0.015);  // the loop is lifted (+y, anterior)
  // The reaction force rises gradually: no step above 0.5 N in 10 ms and it
  // grows from the first seconds to the end.
  EXPECT_LT(soft.largest_force_jump_N, 0.5);
  EXPECT_GT(soft.force_N.back(), soft.force_N[2] + 1.0);
  // The older, stiff-suspension model lets the tip go deeper.
  const PushRun stiff = PushConstantForce(true);
  std::printf("Fig10: soft tip %.3f m inserted %.3f m stretch %.3f m lift %.3f m force %.2f->%.2f N;"
              " stiff tip %.3f m stretch %.3f m\n",
              soft.tip_arc_m, soft.inserted_m, soft.peak_stretch_m, soft.apex_lift_m,
              soft.force_N[2], soft.force_N.back(), stiff.tip_arc_m, stiff.peak_stretch_m);
  EXPECT_GT(stiff.tip_arc_m, soft.tip_arc_m);
  EXPECT_LT(stiff.peak_stretch_m, 0.5 * soft.peak_stretch_m);
}

}  // namespace
}  // namespace ves::model
