// Withdrawing a scope that is bent right at the anus: each joint that leaves
// the anus is straightened by the guide, and the inserted part must keep its
// shape while that happens (docs/model.md, "Withdrawal past a joint"). And a
// scope pushed to the end of its travel is held there.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "tests/station/model/model_test_util.h"

namespace ves::model {
namespace {

using testing::MakeBendTube;
using testing::RigidTissue;
using testing::Sim;

constexpr double kWithdrawSpeed_m_per_s = 0.02;

// When joint k leaves the anus bent by theta, link k becomes the straight
// root: its distal joint moves sideways by at most L_k sin(theta), and with
// the turn carried to the next joint everything beyond moves by that much too.
// Zeroing the turn instead swings the inserted part about the anus: a sample
// r further in moves by r theta (0.26 m x 0.23 rad = 60 mm here, against
// 22 mm x 0.23 = 5 mm). The bound allows twice the link's own share.
constexpr double kLinkShareFactor = 2.0;

TEST(Withdrawal, InsertedPartKeepsItsShapeAsBentJointsLeaveTheAnus) {
  ModelParams params;
  // The colon turns right at the anus (a 90° bend of 5 cm radius), so the
  // joints that pass the anus are bent when they come out again.
  params.colon = MakeBendTube(0.005, M_PI / 2.0, 0.05, 0.4, 0.01, 0.012, RigidTissue(0.2, 0.15));
  params.gravity_W_m_per_s2.setZero();
  Sim sim(params);
  ASSERT_TRUE(sim.RunUntil(6.0, [](const Sim& s) {
    StepInput in;
    in.insertion_m = std::min(0.3, 0.05 * (s.state.time_s + s.params.dt_s));
    return in;
  }));
  const double inserted_m = sim.state.inserted_m;
  ASSERT_NEAR(inserted_m, 0.3, 1e-9);

  // Withdraw 0.15 m: several joints cross the anus, bent by the colon's turn.
  double largest_bend_out_rad = 0.0;
  double largest_motion_m = 0.0;
  double allowed_motion_m = 1e-3;  // 50 steps of the withdrawal itself
  int joints_out = 0;
  const int first_inside_before = sim.state.first_inside_link;
  while (sim.state.inserted_m > 0.15 + 1e-9) {
    const ModelState before = sim.state;
    StepInput in;
    in.insertion_m = inserted_m - kWithdrawSpeed_m_per_s * (sim.state.time_s - 6.0 + sim.params.dt_s);
    sim.StepOnce(in);
    ASSERT_TRUE(sim.out.finite);
    if (sim.state.first_inside_link > before.first_inside_link) {
      ++joints_out;
      const int leaving = before.first_inside_link;
      const double bend_rad = before.bend_rad[leaving].norm();
      largest_bend_out_rad = std::max(largest_bend_out_rad, bend_rad);
      allowed_motion_m = std::max(allowed_motion_m, kLinkShareFactor *
                                                        before.link_length_m[leaving] *
                                                        std::sin(bend_rad));
    }
    for (size_t i = 0; i < before.p_WSample.size(); ++i) {
      if (!sim.state.contact[i].inside) continue;
      largest_motion_m =
          std::max(largest_motion_m, (sim.state.p_WSample[i] - before.p_WSample[i]).norm());
    }
  }
  ASSERT_GT(sim.state.first_inside_link, first_inside_before);
  EXPECT_GE(joints_out, 3);
  EXPECT_GT(largest_bend_out_rad, 0.05) << "the test needs joints that leave the anus bent";
  EXPECT_LT(largest_motion_m, allowed_motion_m);
}

// All of the scope in, the control body rests against the anus: a hand that
// pushes harder moves nothing more. The thrust is held at its end, so the push
// reaches no joint (the pivot at the anus included) through the slide.
TEST(ScopeAtItsEnd, PushingHarderOnAFullyInsertedScopeMovesNothing) {
  ModelParams params;
  params.colon = MakeBendTube(0.005, M_PI / 2.0, 0.05, 0.4, 0.01, 0.012, RigidTissue(0.2, 0.15));
  params.scope.working_length_m = 0.3;
  const auto push = [](double force_N) {
    return [force_N](const Sim&) {
      StepInput in;
      in.thrust_mode = ThrustMode::kForce;
      in.push_force_N = force_N;
      return in;
    };
  };
  Sim sim(params);
  ASSERT_TRUE(sim.RunUntil(20.0, push(20.0)));
  ASSERT_NEAR(sim.state.inserted_m, 0.3, 1e-12) << "the scope must be all in for this test";
  Sim firm = sim;
  Sim hard = sim;
  ASSERT_TRUE(firm.RunUntil(21.0, push(20.0)));
  ASSERT_TRUE(hard.RunUntil(21.0, push(40.0)));
  double largest_difference_m = 0.0;
  for (size_t i = 0; i < firm.state.p_WSample.size(); ++i) {
    largest_difference_m = std::max(
        largest_difference_m, (firm.state.p_WSample[i] - hard.state.p_WSample[i]).norm());
  }
  EXPECT_LT(largest_difference_m, 1e-9);
  EXPECT_NEAR(hard.state.inserted_m, 0.3, 1e-12);
}

}  // namespace
}  // namespace ves::model
