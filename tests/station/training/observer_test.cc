#include "station/training/observer.h"

#include <gtest/gtest.h>

namespace ves::training {
namespace {

// A straight tube along +z: 41 points 1 cm apart (arc 0 .. 0.4 m).
model::ModelParams StraightParams() {
  std::vector<Eigen::Vector3d> points;
  for (int i = 0; i <= 40; ++i) points.emplace_back(0.0, 0.0, 0.01 * i);
  model::ModelParams params;
  params.colon = model::MakeColonFromPoints(points, 0.02, model::TissueParams{});
  return params;
}

struct Fixture {
  model::ModelParams params = StraightParams();
  model::ModelState state = model::MakeInitialState(params);
  model::StepOutput output = model::MakeStepOutput(params);
  Observer observer{params};
};

TEST(Observer, CopiesTheStepAndFindsThePeakWallForce) {
  Fixture f;
  f.output.inserted_m = 0.2;
  f.output.tip_arc_m = 0.19;
  f.output.base_force_N = 1.5;
  f.output.wall_force_N.assign(f.params.colon.points.size(), 0.0);
  f.output.wall_force_N[7] = 2.0;
  f.output.wall_force_N[12] = 3.0;
  InputSample in;
  in.tick = 9;
  in.fluoroscopy_on = true;
  const StepObservation o = f.observer.Observe(in, f.state, f.output);
  EXPECT_DOUBLE_EQ(o.t_s, 10 * f.params.dt_s);
  EXPECT_EQ(o.inserted_m, 0.2);
  EXPECT_EQ(o.tip_arc_m, 0.19);
  EXPECT_EQ(o.base_force_N, 1.5);
  EXPECT_EQ(o.max_wall_force_N, 3.0);
  EXPECT_EQ(o.max_wall_force_arc_m, f.params.colon.points[12].arc_m);
  EXPECT_TRUE(o.fluoroscopy_on);
  EXPECT_EQ(o.segment_wall_force_N.size(), f.params.colon.points.size());
}

TEST(Observer, RedOutWhenTheCameraLooksIntoTheWallItTouches) {
  Fixture f;
  const int tip_sample = static_cast<int>(f.state.samples.size()) - 1;
  f.output.X_WTip = Eigen::Isometry3d::Identity();  // camera looks along +z
  f.output.contact_count = 1;
  f.output.contacts.resize(std::max<std::size_t>(f.output.contacts.size(), 1));
  f.output.contacts[0].sample = tip_sample;
  f.output.contacts[0].penetration_m = 0.001;
  f.output.contacts[0].normal_W = Eigen::Vector3d::UnitZ();  // wall straight ahead
  EXPECT_EQ(f.observer.Observe(InputSample{}, f.state, f.output).redout_fraction, 1.0);
  f.output.contacts[0].normal_W = Eigen::Vector3d::UnitX();  // wall beside the camera
  EXPECT_EQ(f.observer.Observe(InputSample{}, f.state, f.output).redout_fraction, 0.0);
  f.output.contacts[0].normal_W = Eigen::Vector3d::UnitZ();
  f.output.contacts[0].sample = tip_sample - 1;  // another part of the scope touches
  EXPECT_EQ(f.observer.Observe(InputSample{}, f.state, f.output).redout_fraction, 0.0);
}

TEST(Observer, MucosaSeenCountsPointsInFrontWithinRangeCumulatively) {
  Fixture f;
  for (std::size_t i = 0; i < f.state.p_WColon.size(); ++i) {
    f.state.p_WColon[i] = f.params.colon.points[i].rest_position_m;
  }
  // Camera at z = 0.105 m looking along +z: points at z = 0.11 .. 0.16 are
  // closer than 6 cm and on the axis (6 of 41); z = 0.17 is 6.5 cm away.
  f.output.X_WTip = Eigen::Isometry3d(Eigen::Translation3d(0.0, 0.0, 0.105));
  f.output.contact_count = 0;
  const double n = static_cast<double>(f.params.colon.points.size());
  EXPECT_NEAR(f.observer.Observe(InputSample{}, f.state, f.output).mucosa_seen_fraction, 6 / n,
              1e-12);
  // Looking back (-z) from the same place: 0.05 .. 0.10 are new, 6 more.
  f.output.X_WTip.linear() = Eigen::AngleAxisd(model::kPi, Eigen::Vector3d::UnitX()).matrix();
  EXPECT_NEAR(f.observer.Observe(InputSample{}, f.state, f.output).mucosa_seen_fraction, 12 / n,
              1e-12);
  f.observer.Reset();
  f.output.X_WTip = Eigen::Isometry3d(Eigen::Translation3d(0.0, 0.0, 0.105));
  EXPECT_NEAR(f.observer.Observe(InputSample{}, f.state, f.output).mucosa_seen_fraction, 6 / n,
              1e-12);
}

TEST(Observer, ColonPointAtArcInterpolatesAndClamps) {
  Fixture f;
  for (std::size_t i = 0; i < f.state.p_WColon.size(); ++i) {
    f.state.p_WColon[i] = f.params.colon.points[i].rest_position_m;
  }
  EXPECT_NEAR(ColonPointAtArc(f.params, f.state, 0.125).z(), 0.125, 1e-9);
  EXPECT_NEAR(ColonPointAtArc(f.params, f.state, -1.0).z(), 0.0, 1e-12);
  EXPECT_NEAR(ColonPointAtArc(f.params, f.state, 9.0).z(), 0.4, 1e-9);
}

}  // namespace
}  // namespace ves::training
