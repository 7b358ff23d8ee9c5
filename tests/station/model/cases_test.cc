// The model on the shipped cases (patient_db/cases): stability with the input
// held still, and the paper's Fig. 10 on paper-sigmoid.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <functional>
#include <limits>
#include <ostream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "patient_db/case_format.h"
#include "station/training/case_model.h"
#include "station/training/scripted_operator.h"
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

// The same without either of the colon's slow processes (the suspension's
// relaxation and the setting of folds): a purely elastic colon.
ModelParams LoadElasticParams(const std::string& id) {
  ModelParams params = LoadParams(id);
  for (ColonPoint& point : params.colon.points) point.tissue.suspension_relaxation_s = 0.0;
  params.colon_pleat_set_s = 0.0;
  return params;
}

class SettleTest : public ::testing::TestWithParam<const char*> {};

// Insert 18 cm at 30 mm/s, then hold every input still: the elastic state
// settles (with relaxation on, a mobile colon pressed by the scope creeps on:
// RelaxingColon.CreepsMoreAndMoreSlowly; with folds setting, the pleated
// redundant sigmoid still moves at 2e-5 m/s after 5 s).
TEST_P(SettleTest, VelocityDecaysWithInputHeldStill) {
  Sim sim(LoadElasticParams(GetParam()));
  ASSERT_TRUE(sim.RunUntil(6.0, [](const Sim& s) {
    StepInput in;
    in.insertion_m = 0.03 * (s.state.time_s + s.params.dt_s);
    return in;
  }));
  ASSERT_GT(sim.out.contact_count, 0);  // it is pressing on the wall
  const double moving = sim.out.velocity_norm_m_per_s;
  StepInput hold;
  hold.insertion_m = sim.state.inserted_m;
  ASSERT_TRUE(sim.RunUntil(8.0, [&](const Sim&) { return hold; }));
  const double after_2s = sim.out.velocity_norm_m_per_s;
  ASSERT_TRUE(sim.RunUntil(11.0, [&](const Sim&) { return hold; }));
  const double after_5s = sim.out.velocity_norm_m_per_s;
  EXPECT_LT(after_2s, 0.01 * moving);
  EXPECT_LT(after_5s, 1e-6);
}

// The mobile colon's suspension relaxes (TissueParams::
// suspension_relaxation_s): held still, the scope keeps pressing a mobile
// colon, which creeps away from it, more and more slowly.
TEST(RelaxingColon, CreepsMoreAndMoreSlowly) {
  Sim sim(LoadParams("standard-adult"));
  ASSERT_TRUE(sim.RunUntil(6.0, [](const Sim& s) {
    StepInput in;
    in.insertion_m = 0.03 * (s.state.time_s + s.params.dt_s);
    return in;
  }));
  StepInput hold;
  hold.insertion_m = sim.state.inserted_m;
  ASSERT_TRUE(sim.RunUntil(8.0, [&](const Sim&) { return hold; }));
  const double at_2s = sim.out.velocity_norm_m_per_s;
  ASSERT_TRUE(sim.RunUntil(40.0, [&](const Sim&) { return hold; }));
  const double at_34s = sim.out.velocity_norm_m_per_s;
  ASSERT_TRUE(sim.RunUntil(80.0, [&](const Sim&) { return hold; }));
  const double at_74s = sim.out.velocity_norm_m_per_s;
  std::printf("RelaxingColon: speed %.2e m/s at 2 s, %.2e at 34 s, %.2e at 74 s\n", at_2s, at_34s,
              at_74s);
  EXPECT_GT(at_2s, 1e-5);  // it does creep
  // Measured 2026-12-02: 0.60 and 0.53 of the speed before (the bound was
  // 0.6, which the lumen planes over two points crossed by 0.3 %).
  EXPECT_LT(at_34s, 0.7 * at_2s);
  EXPECT_LT(at_74s, 0.7 * at_34s);
  EXPECT_LT(sim.out.peak_fixed_displacement_m, 0.02);
  EXPECT_TRUE(sim.out.finite);
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

// The paper's run: constant push force at the base, no steering, 10 s
// (docs/model.md, "Fig. 10").
PushRun PushConstantForce(bool stiff_colon) {
  constexpr double kPush_N = 6.0;
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

// What of the paper's Fig. 10 the shortening colon keeps: pushed with a
// constant force, the mobile sigmoid is lifted upward (+y) into a loop that
// stretches its mesentery, and the reaction rises gradually; the fixed
// ("--stiff-colon") colon neither loops nor stretches. What it no longer
// shows: the paper's fixed colon let the tip go deeper; here the mobile
// colon yields to the scope and lets the unsteered tip as deep or deeper
// (printed; docs/model.md, "Fig. 10").
TEST(Fig10, ConstantPushLiftsTheMobileSigmoidIntoALoopThatStretchesItsMesentery) {
  const PushRun soft = PushConstantForce(false);
  const PushRun stiff = PushConstantForce(true);
  std::printf("Fig10: soft tip %.3f m inserted %.3f m stretch %.3f m lift %.3f m force %.2f->%.2f N "
              "(largest 10 ms step %.2f N); stiff tip %.3f m inserted %.3f m stretch %.3f m\n",
              soft.tip_arc_m, soft.inserted_m, soft.peak_stretch_m, soft.apex_lift_m,
              soft.force_N[2], soft.force_N.back(), soft.largest_force_jump_N, stiff.tip_arc_m,
              stiff.inserted_m, stiff.peak_stretch_m);
  // The hand has pushed several cm more scope in than the tip advanced: a
  // loop (6.2 cm at 6 N; 12 cm when the wall could lengthen, before the toe
  // in tension was taken out, docs/model-shortening-notes.md).
  EXPECT_GT(soft.inserted_m - soft.tip_arc_m, 0.05);
  // Lifted (+y, anterior): 1.0 cm at 6 N (1.5 cm at 8 N). The paper's
  // colon lifted more because its wall could lengthen; this wall cannot
  // (docs/model.md, "Fig. 10"), and issue #17's 2 cm is not reached.
  EXPECT_GT(soft.apex_lift_m, 0.008);
  EXPECT_GT(soft.peak_stretch_m, 0.015);
  // The reaction rises gradually: no step above 1 N in 10 ms, and it grows.
  EXPECT_LT(soft.largest_force_jump_N, 1.0);
  EXPECT_GT(soft.force_N.back(), soft.force_N[2] + 1.0);
  // The fixed colon: no loop, no stretch.
  EXPECT_LT(stiff.inserted_m - stiff.tip_arc_m, 0.5 * (soft.inserted_m - soft.tip_arc_m));
  EXPECT_LT(stiff.peak_stretch_m, 0.5 * soft.peak_stretch_m);
}

// The simple steering rule (the expert's gain): the knobs turn toward the
// lumen ahead of the tip.
void SteerTowardTheLumen(const Sim& sim, StepInput* in) {
  training::SteerTowardTheLumen(training::Perceive(sim.params, sim.state, sim.out),
                                training::ExpertOperator::kSteerGain_per_s, sim.params.dt_s,
                                &in->knob_up_rad, &in->knob_right_rad);
}

// Position-driven insertion into standard-adult with the simple steering
// rule to 0.6 m, then `withdraw_m` withdrawn at the same speed with the knobs
// held (the tip hooked) and the shaft turned clockwise at 0.5 rad/s, up to
// `roll_max_rad`: a loop formed and withdrawn. The run ends at `end_s`, or
// as the withdrawal ends when `end_s` is 0.
struct LoopDrive {
  double speed_m_per_s{0.02};
  double withdraw_m{0.25};
  double roll_max_rad{std::numeric_limits<double>::infinity()};
  double end_s{45.0};
  ModelExperiments experiments{};  // the product's model by default
};

// `each_step` sees the simulation after every step, and whether that step
// withdrew the scope.
void FormAndWithdrawALoop(const ModelParams& params, const LoopDrive& drive,
                          const std::function<void(const Sim&, bool withdrew)>& each_step) {
  constexpr double kWithdrawAt_m = 0.60;
  Sim sim(params, drive.experiments);
  StepInput in;
  in.thrust_mode = ThrustMode::kPosition;
  double command_m = 0.0;
  bool withdrawing = false;
  const auto withdrawn = [&] { return withdrawing && command_m <= kWithdrawAt_m - drive.withdraw_m; };
  while (drive.end_s > 0.0 ? sim.state.time_s < drive.end_s : !withdrawn()) {
    if (!withdrawing) SteerTowardTheLumen(sim, &in);  // withdrawing, the knobs hold the tip hooked
    if (command_m >= kWithdrawAt_m) withdrawing = true;
    const bool withdraw = withdrawing && !withdrawn();
    if (withdraw) {
      command_m -= drive.speed_m_per_s * sim.params.dt_s;
      in.roll_rad = std::min(drive.roll_max_rad, in.roll_rad + 0.5 * sim.params.dt_s);
    } else if (!withdrawing) {
      command_m += drive.speed_m_per_s * sim.params.dt_s;
    }
    in.insertion_m = command_m;
    sim.StepOnce(in);
    ASSERT_TRUE(sim.out.finite) << "t=" << sim.state.time_s;
    each_step(sim, withdraw);
  }
}

// The same with the defaults: 0.25 m withdrawn, the shaft turned on and on,
// then held until 45 s.
void FormAndWithdrawALoop(const ModelParams& params, const std::function<void(const Sim&)>& each_step) {
  FormAndWithdrawALoop(params, LoopDrive{}, [&](const Sim& sim, bool) { each_step(sim); });
}

// Issue #17's reduction, as a hand does it: position-driven insertion into
// standard-adult with the simple steering rule to 0.6 m, then 0.3 m withdrawn
// at the same speed, the knobs holding the tip hooked round the sigmoid-
// descending junction and the shaft turned clockwise at 0.5 rad/s up to
// `roll_max_rad` (the scripted expert's hand turns it at most 1.5 rad).
struct Reduction {
  double speed_m_per_s;
  double roll_max_rad;
};

void PrintTo(const Reduction& r, std::ostream* os) {
  *os << 1e3 * r.speed_m_per_s << " mm/s, up to " << r.roll_max_rad << " rad";
}

class LoopReduction : public ::testing::TestWithParam<Reduction> {};

// The tip holds (advance allowed) while 0.2-0.3 m comes out: it never comes
// back 2 cm, and the scope in for the tip's place falls by at least 0.15 m:
// the sigmoid pleats onto the straightened scope. The state at 0.6 m is not
// the loop the issue starts from (no loop forms there: docs/model.md, "Known
// limits"); what is shown is the withdrawal. With the shaft turned on and on
// (7.5 rad over this withdrawal) the bent tip turns off its hook and slips
// back 21 cm; at 1 cm/s the hold is fragile (docs/model-shortening-notes.md,
// "The hook and the reduction").
TEST_P(LoopReduction, WithdrawingWithTheTipHookedAndTheShaftTurnedKeepsTheTip) {
  const Reduction r = GetParam();
  LoopDrive drive;
  drive.speed_m_per_s = r.speed_m_per_s;
  drive.withdraw_m = 0.30;
  drive.roll_max_rad = r.roll_max_rad;
  drive.end_s = 0.0;  // stop as the withdrawal ends
  // Scope in when the tip first reached each centimetre of arc on the way in.
  std::vector<double> in_for_tip_cm;
  double start_tip_m = 0.0, lowest_tip_m = 1e9, tip_at_02_m = -1.0, end_tip_m = 0.0, end_in_m = 0.0;
  FormAndWithdrawALoop(LoadParams("standard-adult"), drive, [&](const Sim& sim, bool withdrew) {
    const double tip_m = sim.out.tip_arc_m;
    if (!withdrew) {
      start_tip_m = tip_m;
      while (static_cast<double>(in_for_tip_cm.size()) <= 100.0 * tip_m) {
        in_for_tip_cm.push_back(sim.out.inserted_m);
      }
      return;
    }
    lowest_tip_m = std::min(lowest_tip_m, tip_m);
    if (tip_at_02_m < 0.0 && sim.out.inserted_m <= 0.4) tip_at_02_m = tip_m;
    end_tip_m = tip_m;
    end_in_m = sim.out.inserted_m;
  });
  if (HasFatalFailure()) return;
  const int end_cm = static_cast<int>(100.0 * end_tip_m);
  ASSERT_LT(end_cm, static_cast<int>(in_for_tip_cm.size()));
  const double fall_m = in_for_tip_cm[end_cm] - end_in_m;
  std::printf("LoopReduction %.0f mm/s, roll up to %.1f rad: tip %.3f m at 0.6 m in; after 0.2 m "
              "out %.3f m, after 0.3 m %.3f m (lowest %.3f m); scope in for that place %.3f -> "
              "%.3f m\n",
              1e3 * r.speed_m_per_s, r.roll_max_rad, start_tip_m, tip_at_02_m, end_tip_m,
              lowest_tip_m, in_for_tip_cm[end_cm], end_in_m);
  EXPECT_GT(lowest_tip_m, start_tip_m - 0.02);
  EXPECT_GE(fall_m, 0.15);
}

// The speed and the turn at +-20 % (16-24 mm/s; 1.2-1.8 rad).
INSTANTIATE_TEST_SUITE_P(
    AHandsSettings, LoopReduction,
    ::testing::Values(Reduction{0.020, 1.5}, Reduction{0.016, 1.5}, Reduction{0.024, 1.5},
                      Reduction{0.020, 1.2}, Reduction{0.020, 1.8}),
    [](const ::testing::TestParamInfo<Reduction>& info) {
      return std::to_string(static_cast<int>(1e3 * info.param.speed_m_per_s + 0.5)) + "mm_s_" +
             std::to_string(static_cast<int>(10.0 * info.param.roll_max_rad + 0.5)) + "deci_rad";
    });

// A loop formed and then withdrawn, tip hooked, pleats the sigmoid onto the
// scope (docs/model.md, "Ring contacts"). However the colon folds, it stays
// around the scope: every colon point the scope has passed lies within its
// lumen (plus the wall's give under load) of the scope, so no fold can hang
// off the scope with the scope cutting across its neck (the model before ring
// contacts let the junction fold away by 5 cm and the scope cut across it).
TEST(Tracking, ThePleatedColonStaysAroundTheScope) {
  constexpr double kWallGive_m = 0.01;  // penetration under a wall force of ~10 N
  double farthest_m = 0.0;  // a passed colon point's distance from the scope, beyond its lumen
  double smallest_pleat = 1.0;
  FormAndWithdrawALoop(LoadParams("standard-adult"), [&](const Sim& sim) {
    if (sim.state.step_count % 100 != 0) return;
    const auto& st = sim.state;
    const int first = st.first_inside_sample;
    const int samples = static_cast<int>(st.samples.size());
    const int last_passed = st.contact[samples - 1].segment;
    for (int m = 1; m <= last_passed; ++m) {
      double nearest_m = 1e9;
      for (int i = first; i + 1 < samples; ++i) {
        const Eigen::Vector3d a = st.p_WSample[i], ab = st.p_WSample[i + 1] - a;
        const double t = std::clamp((st.p_WColon[m] - a).dot(ab) / ab.squaredNorm(), 0.0, 1.0);
        nearest_m = std::min(nearest_m, (st.p_WColon[m] - (a + t * ab)).norm());
      }
      farthest_m = std::max(farthest_m, nearest_m - sim.params.colon.points[m].radius_m);
    }
    for (const double r : sim.out.pleat_ratio) smallest_pleat = std::min(smallest_pleat, r);
  });
  std::printf("Tracking: a passed colon point lies at most %.4f m beyond its lumen from the "
              "scope; smallest pleat ratio %.2f\n", farthest_m, smallest_pleat);
  EXPECT_LT(smallest_pleat, 0.9);  // the withdrawal did pleat the colon
  EXPECT_LT(farthest_m, kWallGive_m);
}

// ModelState keeps each gap's length and each point's tether distance from
// the step that moved the colon (colon_gap_m, colon_tether_distance_m); they
// must equal what the current points give, for every point, at every step,
// also where the colon has not moved for a while.
TEST(ColonDerived, KeptGapsAndTetherDistancesMatchTheCurrentPoints) {
  double largest_gap_error_m = 0.0, largest_tether_error_m = 0.0, moved_most_m = 0.0;
  FormAndWithdrawALoop(LoadParams("standard-adult"), [&](const Sim& sim) {
    if (sim.state.step_count % 25 != 0) return;
    const auto& st = sim.state;
    const auto& pts = sim.params.colon.points;
    const int N = static_cast<int>(pts.size());
    for (int i = 0; i < N; ++i) {
      moved_most_m = std::max(moved_most_m, st.colon_displacement_m[i].norm());
      const double tether_m =
          CalcTetherDistance(st.p_WColon[i] - pts[i].tether_anchor_m, pts[i].tether_root_direction,
                             sim.params.colon.mesentery_shear_ratio);
      largest_tether_error_m =
          std::max(largest_tether_error_m, std::abs(st.colon_tether_distance_m[i] - tether_m));
      EXPECT_EQ(sim.out.stretch_m[i], std::max(0.0, tether_m - pts[i].tether_length_m));
      if (i + 1 < N) {
        const double gap_m = (st.p_WColon[i + 1] - st.p_WColon[i]).norm();
        largest_gap_error_m = std::max(largest_gap_error_m, std::abs(st.colon_gap_m[i] - gap_m));
      }
    }
  });
  EXPECT_GT(moved_most_m, 0.02);  // the loop did move the colon
  EXPECT_EQ(largest_gap_error_m, 0.0);
  EXPECT_EQ(largest_tether_error_m, 0.0);
}

// ModelExperiments::lumen_gather_pleat: off, the lumen keeps the case's
// radius; on, it closes onto the scope where folds have set (a withdrawn loop
// sets them), never tighter than the scope plus the clearance, and stays open
// elsewhere.
TEST(LumenGather, TheLumenClosesOntoTheScopeOnlyWhereFoldsHaveSet) {
  const auto narrowest = [](const ModelParams& params, const ModelExperiments& experiments,
                            double* open_where_unset_m) {
    double narrowest_ratio = 1.0;
    *open_where_unset_m = 0.0;
    LoopDrive drive;
    drive.experiments = experiments;
    FormAndWithdrawALoop(params, drive, [&](const Sim& sim, bool) {
      if (sim.state.step_count % 50 != 0) return;
      const auto& pts = sim.params.colon.points;
      const auto& rest_gap_m = sim.state.colon_pair_rest_gap_m;
      const auto& natural_gap_m = sim.scratch.compiled.pair_gap_m;
      const auto& lumen_m = sim.state.colon_lumen_radius_m;
      const double tightest_m = 0.5 * sim.params.scope.outer_diameter_m +
                                sim.scratch.compiled.experiments.lumen_gather_clearance_m;
      const int N = static_cast<int>(pts.size());
      for (int i = 1; i + 1 < N; ++i) {
        narrowest_ratio = std::min(narrowest_ratio, lumen_m[i] / pts[i].radius_m);
        const bool unset =
            rest_gap_m[i - 1] == natural_gap_m[i - 1] && rest_gap_m[i] == natural_gap_m[i];
        if (unset) {
          *open_where_unset_m =
              std::max(*open_where_unset_m, std::abs(lumen_m[i] - pts[i].radius_m));
        }
        EXPECT_GE(lumen_m[i], tightest_m - 1e-12);
      }
    });
    return narrowest_ratio;
  };
  double unset_error_m = 0.0;
  const ModelParams params = LoadParams("standard-adult");
  ModelExperiments experiments;
  EXPECT_EQ(narrowest(params, experiments, &unset_error_m), 1.0);
  experiments.lumen_gather_pleat = 0.7;
  experiments.lumen_gather_clearance_m = 0.005;
  const double gathered = narrowest(params, experiments, &unset_error_m);
  std::printf("LumenGather: the narrowest lumen is %.2f of the case's radius\n", gathered);
  EXPECT_LT(gathered, 0.8);
  EXPECT_EQ(unset_error_m, 0.0);
}

// The largest rise of any colon point's wall force from one step to the next.
double LargestOneStepWallForceRise(const ModelParams& params) {
  double largest_N = 0.0;
  std::vector<double> before;
  FormAndWithdrawALoop(params, [&](const Sim& sim) {
    const auto& now = sim.out.wall_force_N;
    if (before.size() == now.size()) {
      for (size_t m = 0; m < now.size(); ++m) largest_N = std::max(largest_N, now[m] - before[m]);
    }
    before = now;
  });
  return largest_N;
}

// A colon point handed from a sample's segment to the piece between two
// samples (a ring contact) takes its load over ModelParams::ring_onset_s:
// where the colon folds sharply it arrives millimetres inside the ring, and
// taken at once its load was a one-step jump the hand felt as a spike of the
// roll torque (docs/model.md, "Ring contacts").
TEST(Tracking, ARingContactTakesItsLoadGradually) {
  ModelParams at_once = LoadParams("standard-adult");
  at_once.ring_onset_s = 0.0;
  const double gradual_N = LargestOneStepWallForceRise(LoadParams("standard-adult"));
  const double at_once_N = LargestOneStepWallForceRise(at_once);
  std::printf("Tracking: largest one-step rise of a wall force: %.2f N with the ring onset, "
              "%.2f N at once\n", gradual_N, at_once_N);
  EXPECT_LT(gradual_N, 0.5 * at_once_N);
}

// The largest strain of a gap between two points of `region`.
double LargestStrainIn(const Sim& sim, Region region) {
  double largest = 0.0;
  const auto& pts = sim.params.colon.points;
  for (size_t i = 0; i + 1 < pts.size(); ++i) {
    if (pts[i].region != region || pts[i + 1].region != region) continue;
    const double rest = (pts[i + 1].rest_position_m - pts[i].rest_position_m).norm();
    const double now = (sim.state.p_WColon[i + 1] - sim.state.p_WColon[i]).norm();
    largest = std::max(largest, now / rest - 1.0);
  }
  return largest;
}

struct RegionStrains {
  double sigmoid{0.0};
  double rectum{0.0};
};

// 0.4 m inserted with the simple steering rule into standard-adult, with a
// soft toe (10 N to 20 %) in the regions of the mask.
RegionStrains InsertWithToeIn(std::uint32_t toe_regions) {
  constexpr double kSpeed_m_per_s = 0.02;
  ModelParams params = LoadParams("standard-adult");
  params.colon_toe_stiffness_N = 10.0;
  params.colon_toe_strain = 0.2;
  params.colon_toe_regions = toe_regions;
  Sim sim(params);
  StepInput in;
  in.thrust_mode = ThrustMode::kPosition;
  RegionStrains strains;
  while (sim.state.time_s < 20.0) {
    SteerTowardTheLumen(sim, &in);
    in.insertion_m += kSpeed_m_per_s * sim.params.dt_s;
    sim.StepOnce(in);
    EXPECT_TRUE(sim.out.finite);
    if (!sim.out.finite) break;
    strains.sigmoid = std::max(strains.sigmoid, LargestStrainIn(sim, Region::kSigmoid));
    strains.rectum = std::max(strains.rectum, LargestStrainIn(sim, Region::kRectum));
  }
  return strains;
}

// The wall's toe can be confined to some regions (ModelParams::
// colon_toe_regions): a toe in the sigmoid alone (10 N to 20 %, the variant of
// docs/model-shortening-notes.md, "A sigmoid that stretches") lets the
// sigmoid lengthen while the rectum, without it, keeps the wall's modulus;
// with no toe anywhere the sigmoid does not lengthen either.
TEST(WallToe, ConfinedToTheSigmoidLengthensOnlyTheSigmoid) {
  const RegionStrains sigmoid_toe = InsertWithToeIn(1u << static_cast<unsigned>(Region::kSigmoid));
  const RegionStrains no_toe = InsertWithToeIn(0u);
  const RegionStrains toe_everywhere = InsertWithToeIn(~0u);
  std::printf("WallToe: largest gap strain with the toe in the sigmoid: sigmoid %.4f rectum %.4f; "
              "without a toe: sigmoid %.4f rectum %.4f; everywhere: sigmoid %.4f rectum %.4f\n",
              sigmoid_toe.sigmoid, sigmoid_toe.rectum, no_toe.sigmoid, no_toe.rectum,
              toe_everywhere.sigmoid, toe_everywhere.rectum);
  EXPECT_GT(sigmoid_toe.sigmoid, 0.02);  // 5 %: the toe in the sigmoid
  EXPECT_LT(no_toe.sigmoid, 0.01);       // 0.2 %: the wall's modulus
  // The rectum is loaded too: with a toe of its own it lengthens (0.6 %),
  // without one (the toe in the sigmoid alone) it keeps the modulus (0.1 %).
  EXPECT_GT(toe_everywhere.rectum, 0.003);
  EXPECT_LT(sigmoid_toe.rectum, 0.5 * toe_everywhere.rectum);
}

}  // namespace
}  // namespace ves::model
