// Resampling a case's centerline into N segment points (paper eqs. 3-5).
#include <cmath>
#include <stdexcept>

#include <gtest/gtest.h>

#include "station/model/colon.h"
#include "station/model/endoscope.h"  // kPi

namespace ves::model {
namespace {

constexpr double kTolerance_m = 1e-9;

ColonCurve QuarterCircleCurve() {
  // A quarter circle of radius 0.2 m through 9 control points, then straight.
  ColonCurve curve;
  for (int i = 0; i <= 8; ++i) {
    const double phi = (kPi / 2) * i / 8;
    curve.control_points_m.emplace_back(0.0, 0.2 - 0.2 * std::cos(phi), 0.2 * std::sin(phi));
  }
  curve.radius_profile = {{0.0, 0.02}, {0.1, 0.03}};
  TissueParams fixed;
  fixed.suspension_stiffness_N_per_m2 = 2e4;
  curve.regions = {{Region::kRectum, 0.0, 0.1, fixed}, {Region::kSigmoid, 0.1, 1.0, TissueParams{}}};
  return curve;
}

TEST(ColonResample, EqualArcSpacingAndUnitTangents) {
  const ColonSpec colon = ResampleColon(QuarterCircleCurve(), 150);
  ASSERT_EQ(colon.points.size(), 150u);
  const double spacing = colon.points[1].arc_m;
  for (size_t i = 1; i < colon.points.size(); ++i) {
    const double gap = (colon.points[i].rest_position_m - colon.points[i - 1].rest_position_m).norm();
    EXPECT_NEAR(gap, spacing, 0.01 * spacing) << i;
    EXPECT_NEAR(colon.points[i].rest_tangent.norm(), 1.0, kTolerance_m);
    EXPECT_NEAR(colon.points[i].plane_u.dot(colon.points[i].rest_tangent), 0.0, 1e-9);
  }
  // Arc length of a quarter circle: pi/2 * 0.2 = 0.314 m (within the spline's error).
  EXPECT_NEAR(colon.points.back().arc_m, kPi / 2 * 0.2, 0.002);
  EXPECT_TRUE(colon.points.front().rest_position_m.isZero(kTolerance_m));
}

TEST(ColonResample, RadiusAndRegionsFollowArcLength) {
  const ColonSpec colon = ResampleColon(QuarterCircleCurve(), 301);
  for (const ColonPoint& p : colon.points) {
    if (p.arc_m < 0.09) {
      EXPECT_EQ(p.region, Region::kRectum);
      EXPECT_DOUBLE_EQ(p.tissue.suspension_stiffness_N_per_m2, 2e4);
    }
    if (p.arc_m > 0.11) {
      EXPECT_EQ(p.region, Region::kSigmoid);
      EXPECT_NEAR(p.radius_m, 0.03, 1e-12);
    }
  }
  // Linear in between: at 0.05 m (polyline arc) R = 0.025.
  for (const ColonPoint& p : colon.points) {
    if (std::abs(p.arc_m - 0.05) < 0.0006) {
      EXPECT_NEAR(p.radius_m, 0.025, 2e-4);
    }
  }
}

TEST(ColonResample, StiffColonMakesEverySuspensionStiff) {
  ColonSpec colon = ResampleColon(QuarterCircleCurve(), 50);
  MakeSuspensionStiff(&colon);
  for (const ColonPoint& p : colon.points) {
    EXPECT_DOUBLE_EQ(p.tissue.suspension_stiffness_N_per_m2, 2e4);
  }
}

TEST(ColonResample, RejectsBadInputNamingIt) {
  ColonCurve curve = QuarterCircleCurve();
  EXPECT_THROW(ResampleColon(curve, 2), std::invalid_argument);
  curve.radius_profile[1].radius_m = -1.0;
  try {
    ResampleColon(curve, 100);
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("radius_profile[1]"), std::string::npos);
  }
}

}  // namespace
}  // namespace ves::model
