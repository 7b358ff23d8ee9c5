#include "station/render/fluoroscopy_view.h"

#include <gtest/gtest.h>

#include <cmath>

#include "tests/station/render/image_checks.h"
#include "tests/station/render/test_scenes.h"

namespace ves::render {
namespace {

constexpr int kWidth = 320;
constexpr int kHeight = 240;
constexpr int kScopeLevel = 100;             // grey: the scope (near black) is below it
constexpr double kExtentTolerance_px = 2.5;  // thin tube, edges anti-aliased by nothing

FluoroscopyOptions Clean() {
  FluoroscopyOptions options;
  options.width = kWidth;
  options.height = kHeight;
  options.noise_level = 0.0;
  options.blur_sigma_px = 0.0;
  return options;
}

// A straight, thin scope in the horizontal plane z = 0.15 m, running
// Δx = 0.12 m across and Δy = 0.04 m in depth (for the AP view).
SceneGeometry DiagonalScope() {
  SceneGeometry scene = testing::StraightTube();
  scene.scope_points_m.clear();
  for (int i = 0; i <= 10; ++i) {
    const double t = i / 10.0 - 0.5;
    scene.scope_points_m.emplace_back(0.12 * t, 0.04 * t, 0.15);
  }
  scene.scope_diameter_m = 0.002;
  return scene;
}

TEST(FluoroscopyView, TurningNinetyDegreesAboutTheVerticalSwapsWidthAndDepth) {
  // Orthographic: 240 px for 0.40 m at zoom 1 → 600 px/m. AP (yaw 0) shows
  // Δx: 0.12 m → 72 px wide; lateral (yaw 90°, image right = +y) shows the
  // former depth Δy: 0.04 m → 24 px. Plus the 2 mm tube (1.2 px).
  GlContext context;
  FluoroscopyOptions options = Clean();
  options.show_colon = false;
  FluoroscopyView view(&context, options);
  const SceneGeometry scene = DiagonalScope();
  FluoroscopyCamera camera;
  const cv::Vec2i ap = testing::DarkColumnSpan(view.Render(scene, camera), kScopeLevel);
  camera.yaw_rad = testing::kTestPi / 2;
  const cv::Vec2i lateral = testing::DarkColumnSpan(view.Render(scene, camera), kScopeLevel);
  ASSERT_GE(ap[0], 0);
  ASSERT_GE(lateral[0], 0);
  EXPECT_NEAR(ap[1] - ap[0] + 1, 72 + 1.2, kExtentTolerance_px);
  EXPECT_NEAR(lateral[1] - lateral[0] + 1, 24 + 1.2, kExtentTolerance_px);
}

TEST(FluoroscopyView, ZoomTwoDoublesTheProjectedScopeLength) {
  GlContext context;
  FluoroscopyOptions options = Clean();
  options.show_colon = false;
  FluoroscopyView view(&context, options);
  const SceneGeometry scene = DiagonalScope();
  FluoroscopyCamera camera;
  const cv::Vec2i one = testing::DarkColumnSpan(view.Render(scene, camera), kScopeLevel);
  camera.zoom = 2.0;
  const cv::Vec2i two = testing::DarkColumnSpan(view.Render(scene, camera), kScopeLevel);
  const double length_one = one[1] - one[0] + 1;
  const double length_two = two[1] - two[0] + 1;
  EXPECT_NEAR(length_two / length_one, 2.0, 0.05);
  EXPECT_NEAR(0.5 * (two[0] + two[1]), kWidth / 2.0, 2.0);  // zoom about the centre
}

TEST(FluoroscopyView, PanMovesTheImageAndProjectPointAgrees) {
  GlContext context;
  FluoroscopyOptions options = Clean();
  options.show_colon = false;
  FluoroscopyView view(&context, options);
  const SceneGeometry scene = DiagonalScope();
  FluoroscopyCamera camera;
  camera.pan_m = Eigen::Vector2d(0.02, 0.0);  // view centre 2 cm right: scope 12 px left
  const cv::Vec2i span = testing::DarkColumnSpan(view.Render(scene, camera), kScopeLevel);
  const double left = view.ProjectPoint(camera, scene.scope_points_m.front()).x();
  const double right = view.ProjectPoint(camera, scene.scope_points_m.back()).x();
  EXPECT_NEAR(0.5 * (left + right), kWidth / 2.0 - 12.0, 1e-9);
  EXPECT_NEAR(0.5 * (span[0] + span[1] + 1), 0.5 * (left + right), 1.5);
}

TEST(FluoroscopyView, XRayLookScopeDarkestThenRingsOnAGreyField) {
  GlContext context;
  FluoroscopyView view(&context, Clean());
  SceneGeometry scene = testing::StraightTube(0.3, 0.005, 0.025, 0.1);
  FluoroscopyCamera camera;
  camera.center_m = Eigen::Vector3d(0.0, 0.0, 0.15);
  const cv::Mat grey = testing::Grey(view.Render(scene, camera));
  // Field: top-left corner. Scope: on the axis at z = 0.05 m. Ring edge: x = R.
  const auto at = [&](const Eigen::Vector3d& p) {
    const Eigen::Vector2d px = view.ProjectPoint(camera, p);
    return static_cast<int>(grey.at<uchar>(static_cast<int>(px.y()), static_cast<int>(px.x())));
  };
  const int field = grey.at<uchar>(2, 2);
  const int scope = at({0.0, 0.0, 0.05});
  int ring_darkest = 255;
  for (double z = 0.12; z < 0.2; z += 0.0005)
    ring_darkest = std::min(ring_darkest, at({0.0249, 0.0, z}));
  EXPECT_NEAR(field, 204, 3);  // 0.80 grey
  EXPECT_LT(scope, 40);
  EXPECT_LT(ring_darkest, field - 25);
  EXPECT_GT(ring_darkest, scope + 60);
}

TEST(FluoroscopyView, DamageDisplayTintsRingsOverTheThresholdRed) {
  GlContext context;
  FluoroscopyOptions options = Clean();
  options.show_scope = false;
  FluoroscopyView view(&context, options);
  SceneGeometry scene = testing::StraightTube(0.3, 0.005);
  scene.damage_level.assign(scene.colon_centers_m.size(), 0.5);
  for (size_t i = 30; i < 40; ++i) scene.damage_level[i] = 1.4;  // z 0.15 .. 0.195 m
  FluoroscopyCamera camera;
  // Largest red-minus-green among the pixels of the colon between z0 and z1.
  auto redness = [&](const cv::Mat& bgr, double z0, double z1) {
    const int top = static_cast<int>(view.ProjectPoint(camera, {0, 0, z1}).y());
    const int bottom = static_cast<int>(view.ProjectPoint(camera, {0, 0, z0}).y());
    cv::Mat channels[3];
    cv::split(bgr(cv::Range(top, bottom), cv::Range::all()), channels);
    cv::Mat difference;
    cv::subtract(channels[2], channels[1], difference, cv::noArray(), CV_32F);
    double largest = 0.0;
    cv::minMaxLoc(difference, nullptr, &largest);
    return largest;
  };
  const cv::Mat plain = view.Render(scene, camera);
  view.options().damage_display = true;
  const cv::Mat damage = view.Render(scene, camera);
  EXPECT_LT(redness(plain, 0.15, 0.195), 1.0);
  EXPECT_GT(redness(damage, 0.15, 0.195), 60.0);
  EXPECT_LT(redness(damage, 0.05, 0.1), 1.0);  // under the threshold: grey
}

TEST(FluoroscopyView, HiddenIsBlackAndShowingAgainRestoresTheImage) {
  GlContext context;
  FluoroscopyView view(&context, Clean());
  const SceneGeometry scene = testing::BentTube();
  const cv::Mat shown = view.Render(scene, {});
  view.set_visible(false);
  EXPECT_EQ(cv::countNonZero(testing::Grey(view.Render(scene, {}))), 0);
  view.set_visible(true);
  EXPECT_EQ(cv::norm(shown, view.Render(scene, {}), cv::NORM_INF), 0.0);
}

TEST(FluoroscopyView, NonPositiveZoomIsRejected) {
  GlContext context;
  FluoroscopyView view(&context, Clean());
  FluoroscopyCamera camera;
  camera.zoom = 0.0;
  EXPECT_THROW(view.Render(testing::BentTube(), camera), std::invalid_argument);
}

}  // namespace
}  // namespace ves::render
