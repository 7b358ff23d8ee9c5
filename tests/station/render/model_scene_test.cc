#include "station/render/model_scene.h"

#include <gtest/gtest.h>

#include "station/render/endoscope_view.h"
#include "station/training/metric_thresholds.h"
#include "tests/station/render/image_checks.h"

namespace ves::render {
namespace {

// A straight model colon along +z (radius 4 cm, no gravity) with the scope
// inserted 15 cm by position: the tip sits on the axis looking up the tube.
struct StraightRun {
  explicit StraightRun(double knob_up_rad) {
    std::vector<Eigen::Vector3d> points;
    for (int i = 0; i <= 80; ++i) points.emplace_back(0.0, 0.0, 0.01 * i);
    params.colon = model::MakeColonFromPoints(points, 0.04, model::TissueParams{});
    params.gravity_W_m_per_s2.setZero();
    state = model::MakeInitialState(params);
    scratch = model::MakeScratch(params);
    output = model::MakeStepOutput(params);
    model::StepInput input;
    input.knob_up_rad = knob_up_rad;
    for (int i = 1; i <= 600; ++i) {
      input.insertion_m = 0.15 * std::min(1.0, i / 300.0);
      model::Step(params, input, &state, &scratch, &output);
    }
  }
  model::ModelParams params;
  model::ModelState state;
  model::Scratch scratch;
  model::StepOutput output;
};

TEST(ModelScene, CarriesRingsScopeAndCameraFromTheModelState) {
  const StraightRun run(0.0);
  const SceneGeometry scene = SceneFromModel(run.params, run.state, &run.output);
  EXPECT_NO_THROW(ValidateSceneGeometry(scene));
  ASSERT_EQ(scene.colon_centers_m.size(), run.params.colon.points.size());
  EXPECT_EQ(scene.colon_centers_m[10], run.state.p_WColon[10]);
  EXPECT_EQ(scene.colon_arc_m[10], run.params.colon.points[10].arc_m);
  EXPECT_EQ(scene.colon_radius_m[10], 0.04);
  EXPECT_EQ(scene.scope_points_m.size(), run.state.X_WLink.size() + 1);
  EXPECT_TRUE(scene.scope_points_m.back().isApprox(run.state.X_WTip.translation()));
  EXPECT_TRUE(scene.X_WTip.isApprox(run.state.X_WTip));
  EXPECT_EQ(scene.scope_diameter_m, run.params.scope.outer_diameter_m);
  EXPECT_EQ(scene.damage_level.size(), scene.colon_centers_m.size());
  EXPECT_NEAR(scene.X_WTip.translation().z(), 0.15, 1e-6);
}

TEST(ModelScene, DamageLevelIsTheLargerOfForceAndStretchOverThreshold) {
  const StraightRun run(0.0);
  model::StepOutput output = run.output;
  output.wall_force_N.assign(output.wall_force_N.size(), 0.0);
  output.stretch_m.assign(output.stretch_m.size(), 0.0);
  output.wall_force_N[5] = 7.0;   // 7 / 14 N = 0.5
  output.stretch_m[5] = 0.03;     // 0.03 / 0.02 m = 1.5 → 1.5
  output.wall_force_N[6] = 21.0;  // 1.5 by force alone
  const SceneGeometry scene = SceneFromModel(run.params, run.state, &output);
  EXPECT_NEAR(scene.damage_level[5], 1.5, 1e-12);
  EXPECT_NEAR(scene.damage_level[6], 1.5, 1e-12);
  EXPECT_EQ(scene.damage_level[7], 0.0);
}

// The damage display's defaults are the session's damage and pain levels
// (they drifted apart once: the display kept 8 N and 3 cm after scoring
// moved to 14 N and 2 cm).
TEST(ModelScene, DamageScaleIsTheScoringsDamageAndPainLevels) {
  const training::MetricThresholds scoring;
  const DamageScale display;
  EXPECT_EQ(display.damage_wall_force_N, scoring.damage_wall_force_N);
  EXPECT_EQ(display.damage_stretch_m, scoring.pain_stretch_m);
}

TEST(ModelScene, ModelTipViewLooksDownTheLumenAndTheUpKnobMovesIt) {
  // Knob up bends the tip toward its +y (image up): the camera looks up,
  // so the lumen (dark) moves down in the image.
  EndoscopeViewOptions options;
  options.width = 200;
  options.height = 150;
  GlContext context;
  EndoscopeView view(&context, options);
  view.set_mode(EndoscopeMode::kPolygon);
  const StraightRun straight(0.0);
  const StraightRun up(0.35);
  const cv::Point2d centred = testing::DarkestRegion(
      view.Render(SceneFromModel(straight.params, straight.state)).image, 6.0);
  const cv::Point2d moved =
      testing::DarkestRegion(view.Render(SceneFromModel(up.params, up.state)).image, 6.0);
  EXPECT_NEAR(centred.x, 100.0, 8.0);
  EXPECT_NEAR(centred.y, 75.0, 8.0);
  EXPECT_GT(moved.y, centred.y + 15.0) << "lumen at " << moved << " vs " << centred;
}

}  // namespace
}  // namespace ves::render
