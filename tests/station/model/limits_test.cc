// No NaN at the parameter limits the validators allow, validation names the
// bad value, and Step never allocates.
#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdlib>
#include <new>
#include <stdexcept>

#include <gtest/gtest.h>

#include "tests/station/model/model_test_util.h"

// Counting allocator: every operator new in this test binary bumps the count.
namespace {
std::atomic<long> g_allocations{0};
}  // namespace

#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmismatched-new-delete"
void* operator new(std::size_t size) {
  ++g_allocations;
  if (void* p = std::malloc(size == 0 ? 1 : size)) return p;
  throw std::bad_alloc();
}
void operator delete(void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }
#pragma GCC diagnostic pop

namespace ves::model {
namespace {

using testing::MakeBendTube;
using testing::Sim;

ModelParams BendParams(const TissueParams& tissue) {
  ModelParams params;
  params.colon = MakeBendTube(0.1, kPi / 2, 0.06, 0.5, 0.01, 0.015, tissue);
  return params;
}

StepInput Inserting(const Sim& s) {
  StepInput in;
  in.insertion_m = 0.2 * (s.state.time_s + s.params.dt_s);
  in.knob_up_rad = 2.0 * std::sin(3.0 * s.state.time_s);
  in.roll_rad = std::sin(s.state.time_s);
  return in;
}

TEST(ModelLimits, NoNanAtTissueLimits) {
  TissueParams soft;
  soft.suspension_stiffness_N_per_m2 = 0.0;
  soft.suspension_damping_N_s_per_m2 = 1e-3;
  soft.wall_stiffness_N_per_m = 1.0;
  soft.wall_damping_N_s_per_m = 0.0;
  soft.deformation_threshold_m = 0.0;
  soft.static_friction = 0.0;
  soft.dynamic_friction = 0.0;
  soft.neighbor_tension_N = 0.0;
  TissueParams hard;
  hard.suspension_stiffness_N_per_m2 = 1e7;
  hard.suspension_damping_N_s_per_m2 = 1e6;
  hard.wall_stiffness_N_per_m = 1e6;
  hard.wall_damping_N_s_per_m = 1e4;
  hard.deformation_threshold_m = 0.1;
  hard.static_friction = 2.0;
  hard.dynamic_friction = 2.0;
  hard.neighbor_tension_N = 1e4;
  for (const TissueParams& tissue : {soft, hard}) {
    Sim sim(BendParams(tissue));
    EXPECT_TRUE(sim.RunUntil(2.0, Inserting));
  }
}

TEST(ModelLimits, NoNanAtScopeAndStepLimits) {
  for (int variant = 0; variant < 4; ++variant) {
    ModelParams params = BendParams(TissueParams{});
    if (variant == 0) {
      params.scope.joint_damping_N_m_s_per_rad = 1e-9;
      params.scope.flexural_rigidity_N_m2 = 100.0;
    } else if (variant == 1) {
      params.scope.flexural_rigidity_N_m2 = 1e-9;
      params.scope.bending_section_rigidity_N_m2 = 1e-9;
      params.scope.linear_mass_kg_per_m = 10.0;
    } else if (variant == 2) {
      params.dt_s = 0.01;
      params.scope.link_count = 3;
    } else {
      params.dt_s = 1e-5;
      params.scope.link_count = 200;
    }
    Sim sim(params);
    EXPECT_TRUE(sim.RunUntil(variant == 3 ? 0.05 : 1.0, Inserting)) << "variant " << variant;
  }
}

TEST(ModelLimits, ForceModeAtLimitsStaysFinite) {
  Sim sim(BendParams(TissueParams{}));
  EXPECT_TRUE(sim.RunUntil(2.0, [](const Sim&) {
    StepInput in;
    in.thrust_mode = ThrustMode::kForce;
    in.push_force_N = 100.0;
    in.knob_right_rad = 10.0;  // beyond the scope's angulation: clamped
    return in;
  }));
  EXPECT_LE(sim.state.inserted_m, sim.params.scope.working_length_m);
}

TEST(ModelValidation, RejectsBadValuesNamingThem) {
  ModelParams params = BendParams(TissueParams{});
  params.scope.link_count = 2;
  try {
    MakeInitialState(params);
    FAIL() << "link_count = 2 accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("link_count"), std::string::npos);
  }
  params = BendParams(TissueParams{});
  params.colon.points[3].tissue.dynamic_friction = 0.9;  // above static 0.3
  EXPECT_THROW(MakeInitialState(params), std::invalid_argument);
  params = BendParams(TissueParams{});
  params.dt_s = 0.0;
  EXPECT_THROW(MakeInitialState(params), std::invalid_argument);
}

TEST(ModelAllocation, StepNeverAllocates) {
  ModelParams params = BendParams(TissueParams{});
  Sim sim(params);
  ASSERT_TRUE(sim.RunUntil(0.5, Inserting));  // warm: contacts exist
  ASSERT_GT(sim.out.contact_count, 0);
  const long before = g_allocations.load();
  for (int i = 0; i < 500; ++i) sim.StepOnce(Inserting(sim));
  EXPECT_EQ(g_allocations.load() - before, 0);
  // The counter does count: a vector allocates.
  std::vector<double> probe(10);
  EXPECT_GT(g_allocations.load() - before, 0);
}

// A mobile colon that pleats, stretches its mesentery and relaxes keeps Step
// allocation-free and finite through an insertion and a withdrawal, and a
// bad wall law is refused.
TEST(ModelAllocation, ShorteningColonNeverAllocatesAndStaysFinite) {
  TissueParams mobile;  // the defaults: a mobile, sigmoid-like region
  ModelParams params = BendParams(mobile);
  Sim sim(params);
  ASSERT_TRUE(sim.RunUntil(1.0, Inserting));
  ASSERT_GT(sim.out.contact_count, 0);
  const long before = g_allocations.load();
  const double deepest_m = sim.state.inserted_m;
  ASSERT_TRUE(sim.RunUntil(2.0, [&](const Sim& s) {
    StepInput in;
    in.insertion_m = deepest_m - 0.1 * (s.state.time_s - 1.0);  // withdraw 10 cm
    in.roll_rad = 0.5 * (s.state.time_s - 1.0);                // turning clockwise
    return in;
  }));
  EXPECT_EQ(g_allocations.load() - before, 0);
  EXPECT_TRUE(sim.out.finite);
  params.colon_toe_strain = -0.1;
  EXPECT_THROW(MakeInitialState(params), std::invalid_argument);
  params = BendParams(mobile);
  params.colon_pleat_stiffness_N = params.colon_tension_stiffness_N * 2.0;
  EXPECT_THROW(MakeInitialState(params), std::invalid_argument);
}

// The benches' experiments are checked when the model is compiled: a bad
// value is refused, the product's (the defaults) pass.
TEST(ModelExperimentsLimits, ABadExperimentIsRefusedWhenTheModelIsCompiled) {
  const ModelParams params = BendParams(TissueParams{});
  EXPECT_NO_THROW(MakeScratch(params));
  ModelExperiments experiments;
  experiments.lumen_gather_pleat = 1.5;
  EXPECT_THROW(MakeScratch(params, experiments), std::invalid_argument);
  experiments = ModelExperiments{};
  experiments.lumen_gather_clearance_m = -0.001;
  EXPECT_THROW(CompileModel(params, experiments), std::invalid_argument);
}

}  // namespace
}  // namespace ves::model
