// Contact geometry (docs/model.md, "Contact"): how far a sample is from the
// lumen centre between two colon points that are displaced differently.
#include <gtest/gtest.h>

#include "station/model/internal.h"
#include "tests/station/model/model_test_util.h"

namespace ves::model {
namespace {

constexpr double kTolerance_m = 1e-9;

// A straight tube along +z (points 1 cm apart, lumen radius 20 mm); point 10
// is moved 10 mm sideways, point 11 stays, and the lumen's planes keep the
// state's tangents (those of the last step: here, the rest ones). A sample halfway
// along the segment between them, on the line joining the two centres, lies
// on the lumen's axis: its offset from the centre is zero, so l = a - R.
// Blending the two in-plane distances (10 mm and 0 mm) instead would put it
// 5 mm off the axis.
TEST(ContactGeometry, ASampleOnATiltedSegmentsAxisIsOnTheAxis) {
  ModelParams params;
  params.colon = testing::MakeStraightTube(0.5, 0.01, 0.02, TissueParams{});
  ModelState state = MakeInitialState(params);
  const int k = 10;
  const ColonPoint& point = params.colon.points[k];
  state.colon_displacement_m[k] = 0.01 * point.plane_u;
  state.p_WColon[k] = point.rest_position_m + state.colon_displacement_m[k];
  const Eigen::Vector3d on_axis = 0.5 * (state.p_WColon[k] + state.p_WColon[k + 1]);

  const internal::SegmentHit hit = internal::CalcSegmentHit(params, state, k, on_axis);
  const double scope_radius_m = 0.5 * params.scope.outer_diameter_m;
  EXPECT_NEAR(hit.t, 0.5, kTolerance_m);
  EXPECT_NEAR(hit.penetration_m, scope_radius_m - 0.02, kTolerance_m);

  // 3 mm off that axis along plane_v: the offset is 3 mm.
  const Eigen::Vector3d off_axis = on_axis + 0.003 * point.plane_v;
  const internal::SegmentHit off = internal::CalcSegmentHit(params, state, k, off_axis);
  EXPECT_NEAR(off.penetration_m, 0.003 + scope_radius_m - 0.02, kTolerance_m);
  EXPECT_NEAR(off.normal.dot(point.plane_v), 1.0, kTolerance_m);
}

}  // namespace
}  // namespace ves::model
