#include "station/render/endoscope_view.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <string>

#include "tests/station/render/image_checks.h"
#include "tests/station/render/test_scenes.h"

namespace ves::render {
namespace {

constexpr int kWidth = 320;
constexpr int kHeight = 240;

EndoscopeViewOptions SmallView() {
  EndoscopeViewOptions options;
  options.width = kWidth;
  options.height = kHeight;
  return options;
}

double Distance(const cv::Point2d& a, const Eigen::Vector2d& b) {
  return std::hypot(a.x - b.x(), a.y - b.y());
}

TEST(EndoscopeView, DarkestRegionIsAtTheImageCentreOnTheAxisOfAStraightTube) {
  // The light at the lens falls off as 1/d², so the far lumen straight
  // ahead (on the optical axis, the image centre) is the darkest place.
  constexpr double kCentreTolerance_px = 0.04 * kWidth;
  GlContext context;
  EndoscopeView view(&context, SmallView());
  for (EndoscopeMode mode : {EndoscopeMode::kPolygon, EndoscopeMode::kTexture}) {
    view.set_mode(mode);
    const EndoscopeFrame frame = view.Render(testing::StraightTube());
    const cv::Point2d dark = testing::DarkestRegion(frame.image, 8.0);
    EXPECT_LT(Distance(dark, Eigen::Vector2d(kWidth / 2.0, kHeight / 2.0)), kCentreTolerance_px)
        << EndoscopeModeName(mode) << " darkest at " << dark;
    EXPECT_EQ(frame.red_out_share, 0.0);
    EXPECT_FALSE(frame.lens_in_wall);
  }
}

// At the cecum the view shows the colon's closed end, lit by the lens
// 3.5 cm ahead, where an open tube left the black behind the mesh.
TEST(EndoscopeView, TheCecumsPoleIsLitAtTheEndOfTheColon) {
  GlContext context;
  EndoscopeView view(&context, SmallView());
  for (EndoscopeMode mode : {EndoscopeMode::kPolygon, EndoscopeMode::kTexture}) {
    view.set_mode(mode);
    const EndoscopeFrame frame = view.Render(testing::StraightTube(0.5, 0.005, 0.025, 0.48));
    const cv::Mat centre = frame.image(cv::Rect(kWidth / 2 - 10, kHeight / 2 - 10, 20, 20));
    EXPECT_GT(cv::mean(centre)[2], 60.0) << EndoscopeModeName(mode);
    EXPECT_EQ(frame.red_out_share, 0.0) << EndoscopeModeName(mode);
    EXPECT_FALSE(frame.lens_in_wall) << EndoscopeModeName(mode);
  }
}

// The cecum a trainee can confirm (cecum_landmarks.h): from 6 cm before the
// tube's end, the ileocaecal valve on the wall, the triradiate fold and the
// appendiceal orifice on the pole change the image in every view mode, and
// the end stays lit like the wall (the relief takes the wall's light, not a
// shadow over the whole pole). With VES_TEST_SHOTS_DIR set the views are
// written there as cecum_<mode>.png.
TEST(EndoscopeView, TheCecumsLandmarksAreDrawnInEveryModeAndLit) {
  EndoscopeViewOptions options;
  options.width = 640;
  options.height = 480;
  const SceneGeometry scene = testing::StraightTube(0.5, 0.005, 0.025, 0.44);
  GlContext context;
  for (EndoscopeMode mode :
       {EndoscopeMode::kWireframe, EndoscopeMode::kPolygon, EndoscopeMode::kTexture}) {
    options.mesh.cecum_landmarks = false;
    EndoscopeView plain_view(&context, options);
    plain_view.set_mode(mode);
    const cv::Mat plain = plain_view.Render(scene).image.clone();
    options.mesh.cecum_landmarks = true;
    EndoscopeView view(&context, options);
    view.set_mode(mode);
    const cv::Mat marked = view.Render(scene).image.clone();
    cv::Mat diff;
    cv::absdiff(plain, marked, diff);
    cv::Mat grey;
    cv::cvtColor(diff, grey, cv::COLOR_BGR2GRAY);
    const double changed = static_cast<double>(cv::countNonZero(grey > 20)) / grey.total();
    EXPECT_GT(changed, 0.01) << EndoscopeModeName(mode) << ": the landmarks do not show";
    if (mode != EndoscopeMode::kWireframe) {
      const double plain_light = cv::mean(plain)[2];
      const double marked_light = cv::mean(marked)[2];
      EXPECT_GT(marked_light, 0.8 * plain_light) << EndoscopeModeName(mode) << ": the cecum dimmed";
    }
    if (const char* dir = std::getenv("VES_TEST_SHOTS_DIR")) {
      cv::imwrite(std::string(dir) + "/cecum_" + EndoscopeModeName(mode) + ".png", marked);
      cv::imwrite(std::string(dir) + "/cecum_" + EndoscopeModeName(mode) + "_plain.png", plain);
    }
  }
}

TEST(EndoscopeView, LightAtTheLensFallsOffWithDistance) {
  // Straight tube, R = 25 mm, no folds, camera on the axis. A ray at angle θ
  // meets the wall at d = R / sin θ with incidence cos = sin θ, so the red
  // channel is 255 · 0.86 · (0.02 + 1.1 · sin θ · min(1, (0.03 / d)²)):
  // θ = 35°: d = 43.6 mm → 69.9;  θ = 12°: d = 120 mm → 7.5; ratio 0.107.
  // Without the 1/d² falloff the ratio would be 0.38.
  EndoscopeViewOptions options = SmallView();
  options.mesh.fold_depth = 0.0;
  GlContext context;
  EndoscopeView view(&context, options);
  view.set_mode(EndoscopeMode::kPolygon);
  const cv::Mat image = view.Render(testing::StraightTube()).image;
  const auto red_at = [&](double theta_rad) {
    const Eigen::Vector2d px =
        view.ProjectTipPoint(Eigen::Vector3d(std::sin(theta_rad), 0.0, std::cos(theta_rad)));
    const cv::Rect box(static_cast<int>(px.x()) - 1, static_cast<int>(px.y()) - 1, 3, 3);
    return cv::mean(image(box))[2];
  };
  const double near_wall = red_at(35.0 * testing::kTestPi / 180.0);
  const double far_wall = red_at(12.0 * testing::kTestPi / 180.0);
  EXPECT_NEAR(near_wall, 69.9, 8.0);
  EXPECT_NEAR(far_wall / near_wall, 0.107, 0.03);
}

TEST(EndoscopeView, TurningTheKnobMovesTheDarkLumen) {
  // Tip turned +20° about its x axis: the tube axis (W +z) is then seen in
  // direction R_x(20°)ᵀ·z = (0, sin 20°, cos 20°) of the tip frame, i.e.
  // f·20° pixels above the centre (tip +y is image up; equidistant lens:
  // r = f·θ).
  constexpr double kAngle_rad = 20.0 * testing::kTestPi / 180.0;
  GlContext context;
  EndoscopeView view(&context, SmallView());
  view.set_mode(EndoscopeMode::kPolygon);
  SceneGeometry scene = testing::StraightTube();
  scene.X_WTip = testing::TurnedAboutTipX(scene.X_WTip, kAngle_rad);
  const cv::Point2d dark = testing::DarkestRegion(view.Render(scene).image, 8.0);
  const Eigen::Vector2d expected =
      view.ProjectTipPoint(Eigen::Vector3d(0.0, std::sin(kAngle_rad), std::cos(kAngle_rad)));
  const double shift_px = view.focal_px_per_rad() * kAngle_rad;
  EXPECT_NEAR(kHeight / 2.0 - expected.y(), shift_px, 1e-9);
  EXPECT_GT(kHeight / 2.0 - dark.y, 0.6 * shift_px) << "darkest at " << dark;
  EXPECT_LT(Distance(dark, expected), 0.3 * shift_px) << "darkest at " << dark;
  EXPECT_NEAR(dark.x, kWidth / 2.0, 0.04 * kWidth);
}

class EndoscopeModes : public ::testing::Test {
 protected:
  void SetUp() override {
    view_ = std::make_unique<EndoscopeView>(&context_, SmallView());
    scene_ = testing::StraightTube();
    // The image outside a disc around the centre shows the lit wall near the lens.
    periphery_ = cv::Mat(kHeight, kWidth, CV_8U, cv::Scalar(255));
    cv::circle(periphery_, cv::Point(kWidth / 2, kHeight / 2), kHeight / 2, cv::Scalar(0), -1);
  }
  cv::Mat RenderIn(EndoscopeMode mode) {
    view_->set_mode(mode);
    return view_->Render(scene_).image;
  }
  GlContext context_;
  std::unique_ptr<EndoscopeView> view_;
  SceneGeometry scene_;
  cv::Mat periphery_;
};

TEST_F(EndoscopeModes, WireframeShowsBackgroundBetweenItsLines) {
  const cv::Mat wire = RenderIn(EndoscopeMode::kWireframe);
  const cv::Mat polygon = RenderIn(EndoscopeMode::kPolygon);
  EXPECT_GT(testing::DarkShare(wire, periphery_, 8), 0.6);      // mostly background
  EXPECT_LT(testing::DarkShare(polygon, periphery_, 8), 0.01);  // solid lit wall
  // ...but the lines are there.
  EXPECT_GT(testing::DarkShare(wire, periphery_, 8), 0.0);
  double brightest = 0.0;
  cv::minMaxLoc(testing::Grey(wire), nullptr, &brightest);
  EXPECT_GT(brightest, 100.0);
}

TEST_F(EndoscopeModes, TextureHasMoreLocalVarianceThanFlatPolygons) {
  const double texture = testing::MeanLocalVariance(RenderIn(EndoscopeMode::kTexture), periphery_);
  const double polygon = testing::MeanLocalVariance(RenderIn(EndoscopeMode::kPolygon), periphery_);
  EXPECT_GT(texture, 3.0 * polygon) << "texture " << texture << " polygon " << polygon;
}

TEST_F(EndoscopeModes, ModesSwitchBetweenAnyTwoFramesWithoutLeftovers) {
  const cv::Mat first = RenderIn(EndoscopeMode::kPolygon);
  RenderIn(EndoscopeMode::kWireframe);
  RenderIn(EndoscopeMode::kTexture);
  const cv::Mat again = RenderIn(EndoscopeMode::kPolygon);
  EXPECT_EQ(cv::norm(first, again, cv::NORM_INF), 0.0);
  EXPECT_GT(cv::norm(first, RenderIn(EndoscopeMode::kTexture), cv::NORM_L1), 0.0);
}

TEST(EndoscopeView, LensFacingTheWallCloselyGoesRed) {
  // Tip 2 mm from the wall (radius 25 mm), looking straight at it (+x):
  // the wall is within the 5 mm red-out distance for view angles with
  // 2 mm / cos θ < 5 mm, θ < 66° — most of the 70° half-diagonal image.
  GlContext context;
  EndoscopeView view(&context, SmallView());
  view.set_mode(EndoscopeMode::kTexture);
  SceneGeometry scene = testing::StraightTube();
  scene.X_WTip.linear() =
      Eigen::AngleAxisd(testing::kTestPi / 2, Eigen::Vector3d::UnitY()).toRotationMatrix();
  scene.X_WTip.translation() = Eigen::Vector3d(0.023, 0.0, 0.1);
  const EndoscopeFrame frame = view.Render(scene);
  EXPECT_FALSE(frame.lens_in_wall);
  EXPECT_GT(frame.red_out_share, 0.5);
  EXPECT_LT(frame.red_out_share, 1.0);
  const cv::Vec3b centre = frame.image.at<cv::Vec3b>(kHeight / 2, kWidth / 2);  // BGR
  EXPECT_GT(centre[2], 150);
  EXPECT_LT(centre[1], 60);
}

TEST(EndoscopeView, LensInsideTheWallIsAllRed) {
  GlContext context;
  EndoscopeView view(&context, SmallView());
  SceneGeometry scene = testing::StraightTube();
  scene.X_WTip.translation() = Eigen::Vector3d(0.03, 0.0, 0.1);  // 5 mm beyond R = 25 mm
  for (EndoscopeMode mode : {EndoscopeMode::kWireframe, EndoscopeMode::kTexture}) {
    view.set_mode(mode);
    const EndoscopeFrame frame = view.Render(scene);
    EXPECT_TRUE(frame.lens_in_wall);
    EXPECT_EQ(frame.red_out_share, 1.0);
    const cv::Scalar mean = cv::mean(frame.image);
    EXPECT_GT(mean[2], 150.0);
    EXPECT_LT(mean[1], 30.0);
  }
}

TEST(EndoscopeView, InconsistentSceneIsRejected) {
  GlContext context;
  EndoscopeView view(&context, SmallView());
  SceneGeometry scene = testing::StraightTube();
  scene.colon_tangents.pop_back();
  EXPECT_THROW(view.Render(scene), std::invalid_argument);
  EXPECT_THROW(ParseEndoscopeMode("x-ray"), std::invalid_argument);
  EXPECT_EQ(ParseEndoscopeMode("wireframe"), EndoscopeMode::kWireframe);
}

}  // namespace
}  // namespace ves::render
