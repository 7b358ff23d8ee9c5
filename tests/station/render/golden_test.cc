// Golden images of a fixed synthetic state (the bent tube, damage on the
// bend). Compared by mean absolute difference per pixel and channel, a
// tolerance that survives llvmpipe/Mesa versions (rasterisation rules and
// float rounding move edges by a pixel, not the picture). Regenerate after
// an intended change of the look with
//   VES_UPDATE_GOLDEN=1 ctest --test-dir build -R Golden
// and review the PNGs in tests/station/render/golden/ before committing.
#include <gtest/gtest.h>

#include <cstdlib>
#include <opencv2/imgcodecs.hpp>
#include <string>

#include "station/render/endoscope_view.h"
#include "station/render/fluoroscopy_view.h"
#include "tests/station/render/test_scenes.h"

namespace ves::render {
namespace {

// Grey levels, mean over pixels and channels. The fluoroscopic image is
// mostly empty field, so its tolerance is tighter: losing the scope alone
// changes its mean by about 3.
constexpr double kEndoscopeTolerance = 3.0;
constexpr double kFluoroscopyTolerance = 0.75;
constexpr int kWidth = 200;
constexpr int kHeight = 150;

std::string GoldenPath(const std::string& name) {
  return std::string(VES_SOURCE_DIR) + "/tests/station/render/golden/" + name + ".png";
}

double MeanAbsDiff(const cv::Mat& a, const cv::Mat& b) {
  cv::Mat diff;
  cv::absdiff(a, b, diff);
  const cv::Scalar m = cv::mean(diff);
  return (m[0] + m[1] + m[2]) / 3.0;
}

// Compares with the stored golden image, or rewrites it under VES_UPDATE_GOLDEN.
void ExpectMatchesGolden(const std::string& name, const cv::Mat& image, double tolerance) {
  const std::string path = GoldenPath(name);
  const char* update = std::getenv("VES_UPDATE_GOLDEN");
  if (update != nullptr && std::string(update) == "1") {
    ASSERT_TRUE(cv::imwrite(path, image)) << path;
    GTEST_SKIP() << "rewrote " << path;
  }
  const cv::Mat golden = cv::imread(path, cv::IMREAD_COLOR);
  ASSERT_FALSE(golden.empty()) << "missing " << path << " (VES_UPDATE_GOLDEN=1 writes it)";
  ASSERT_EQ(golden.size(), image.size());
  const double difference = MeanAbsDiff(image, golden);
  EXPECT_LT(difference, tolerance) << name;
  if (difference >= tolerance) {
    cv::imwrite(std::string(VES_BINARY_DIR) + "/golden_actual_" + name + ".png", image);
  }
}

SceneGeometry GoldenScene() {
  SceneGeometry scene = testing::BentTube();
  scene.damage_level.assign(scene.colon_centers_m.size(), 0.2);
  for (size_t i = 45; i < 60; ++i) scene.damage_level[i] = 1.5;
  return scene;
}

cv::Mat Endoscope(EndoscopeMode mode, const SceneGeometry& scene) {
  GlContext context;
  EndoscopeViewOptions options;
  options.width = kWidth;
  options.height = kHeight;
  EndoscopeView view(&context, options);
  view.set_mode(mode);
  return view.Render(scene).image;
}

cv::Mat Fluoroscopy(double yaw_rad, bool damage) {
  GlContext context;
  FluoroscopyOptions options;
  options.width = kWidth;
  options.height = kHeight;
  options.damage_display = damage;
  FluoroscopyView view(&context, options);
  FluoroscopyCamera camera;
  camera.yaw_rad = yaw_rad;
  camera.center_m = Eigen::Vector3d(0.05, 0.0, 0.15);
  return view.Render(GoldenScene(), camera);
}

TEST(Golden, EndoscopeWireframe) {
  ExpectMatchesGolden("endoscope_wireframe", Endoscope(EndoscopeMode::kWireframe, GoldenScene()),
                      kEndoscopeTolerance);
}

TEST(Golden, EndoscopePolygon) {
  ExpectMatchesGolden("endoscope_polygon", Endoscope(EndoscopeMode::kPolygon, GoldenScene()),
                      kEndoscopeTolerance);
}

TEST(Golden, EndoscopeTexture) {
  ExpectMatchesGolden("endoscope_texture", Endoscope(EndoscopeMode::kTexture, GoldenScene()),
                      kEndoscopeTolerance);
}

TEST(Golden, FluoroscopyAp) {
  ExpectMatchesGolden("fluoroscopy_ap", Fluoroscopy(0.0, false), kFluoroscopyTolerance);
}

TEST(Golden, FluoroscopyLateralWithDamage) {
  ExpectMatchesGolden("fluoroscopy_lateral_damage", Fluoroscopy(testing::kTestPi / 2, true),
                      kFluoroscopyTolerance);
}

TEST(Golden, ToleranceCatchesARealChange) {
  // The comparison must be able to fail: the tip 1 cm further in, or the
  // C-arm turned 30°, is well over the tolerance.
  SceneGeometry moved = GoldenScene();
  moved.X_WTip.translation().z() += 0.01;
  EXPECT_GT(MeanAbsDiff(Endoscope(EndoscopeMode::kPolygon, moved),
                        Endoscope(EndoscopeMode::kPolygon, GoldenScene())),
            kEndoscopeTolerance);
  EXPECT_GT(MeanAbsDiff(Fluoroscopy(0.5, true), Fluoroscopy(testing::kTestPi / 2, true)),
            kFluoroscopyTolerance);
}

}  // namespace
}  // namespace ves::render
