// A radiograph's labels: the view's name, the patient's side at each edge
// and a scale bar, from the C-arm's angle and zoom (no GL needed).
#include "station/render/fluoroscopy_labels.h"

#include <gtest/gtest.h>

#include <cmath>
#include <opencv2/imgproc.hpp>

namespace ves::render {
namespace {

constexpr double kPi = 3.14159265358979323846;
const cv::Size kImage(640, 480);

FluoroscopyLabels At(double yaw_deg, double tilt_deg = 0.0, double zoom = 1.0) {
  FluoroscopyCamera camera;
  camera.yaw_rad = yaw_deg * kPi / 180.0;
  camera.pitch_rad = tilt_deg * kPi / 180.0;
  camera.zoom = zoom;
  camera.field_height_m = 0.48;  // 1000 px per metre at zoom 1 on a 480 px image
  return CalcFluoroscopyLabels(camera, kImage);
}

TEST(FluoroscopyLabels, FrontalViewsShowRightAndLeftAsRadiographsDo) {
  // AP, as if facing the patient: the patient's right on the image's left.
  const FluoroscopyLabels ap = At(0.0);
  EXPECT_EQ(ap.view, "AP");
  EXPECT_EQ(ap.left_edge, "R");
  EXPECT_EQ(ap.right_edge, "L");
  const FluoroscopyLabels pa = At(180.0);
  EXPECT_EQ(pa.view, "PA");
  EXPECT_EQ(pa.left_edge, "L");
  EXPECT_EQ(pa.right_edge, "R");
}

TEST(FluoroscopyLabels, LateralViewsShowAnteriorAndPosterior) {
  // FluoroscopyView at yaw 90 degrees: image right is -y, posterior.
  const FluoroscopyLabels lateral = At(90.0);
  EXPECT_EQ(lateral.view, "LAT");
  EXPECT_EQ(lateral.left_edge, "A");
  EXPECT_EQ(lateral.right_edge, "P");
  const FluoroscopyLabels other = At(-90.0);
  EXPECT_EQ(other.view, "LAT");
  EXPECT_EQ(other.right_edge, "A");
}

TEST(FluoroscopyLabels, ObliqueAndTiltedViewsSayTheirAngles) {
  EXPECT_EQ(At(35.0).view, "OBL +35");
  EXPECT_EQ(At(35.0).right_edge, "L");  // still mostly frontal
  EXPECT_EQ(At(-120.0).view, "OBL -120");
  EXPECT_EQ(At(0.0, 20.0).view, "AP tilt +20");
  EXPECT_EQ(At(400.0).view, "OBL +40");  // angles wrap
}

TEST(FluoroscopyLabels, TheScaleBarIsARoundLengthOfAboutAFifthOfTheWidth) {
  // 1000 px/m: a fifth of 640 px is 128 mm -> 10 cm, 100 px.
  const FluoroscopyLabels one = At(0.0);
  EXPECT_DOUBLE_EQ(one.scale_bar_m, 0.1);
  EXPECT_NEAR(one.scale_bar_px, 100.0, 1e-9);
  // Zoom 4: 4000 px/m, a fifth is 32 mm; of 2 and 5 cm the nearer by
  // ratio is 5 cm (x1.56 against x1.6), 200 px.
  const FluoroscopyLabels four = At(0.0, 0.0, 4.0);
  EXPECT_DOUBLE_EQ(four.scale_bar_m, 0.05);
  EXPECT_NEAR(four.scale_bar_px, 200.0, 1e-9);
  // Zoom 8: a fifth is 16 mm -> 2 cm, 160 px.
  EXPECT_DOUBLE_EQ(At(0.0, 0.0, 8.0).scale_bar_m, 0.02);
}

TEST(FluoroscopyLabels, DrawnAtTheCornersAndEdgesOnly) {
  cv::Mat image(kImage, CV_8UC3, cv::Scalar(128, 128, 128));
  DrawFluoroscopyLabels(At(0.0), &image);
  const auto changed = [&](const cv::Rect& r) {
    cv::Mat grey;
    cv::cvtColor(image(r), grey, cv::COLOR_BGR2GRAY);
    return cv::countNonZero(grey != 128);
  };
  EXPECT_GT(changed({520, 0, 120, 60}), 50);                  // view name, top right
  EXPECT_EQ(changed({0, 0, 400, 60}), 0);                     // top left: free for a caption
  EXPECT_GT(changed({0, 200, 60, 80}), 20);                   // R, left edge
  EXPECT_GT(changed({580, 200, 60, 80}), 20);                 // L, right edge
  EXPECT_GT(changed({0, 400, 160, 80}), 200);                 // scale bar
  EXPECT_EQ(changed({200, 100, 240, 280}), 0);                // the image itself
}

TEST(CentreZoomOnTip, AtZoomOneTheColonAtTwoTheTip) {
  FluoroscopyCamera framing;
  framing.center_m = {0.0, 0.0, 0.2};
  const Eigen::Vector3d tip(0.1, -0.05, 0.3);
  framing.zoom = 1.0;
  EXPECT_TRUE(CentreZoomOnTip(framing, tip).center_m.isApprox(framing.center_m));
  framing.zoom = 2.0;
  EXPECT_TRUE(CentreZoomOnTip(framing, tip).center_m.isApprox(tip));
  framing.zoom = 1.5;
  EXPECT_TRUE(CentreZoomOnTip(framing, tip).center_m.isApprox(0.5 * (tip + framing.center_m)));
  framing.zoom = 0.5;
  EXPECT_TRUE(CentreZoomOnTip(framing, tip).center_m.isApprox(framing.center_m));
}

}  // namespace
}  // namespace ves::render
