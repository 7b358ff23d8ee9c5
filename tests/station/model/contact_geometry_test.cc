// Contact geometry (docs/model.md, "Contact"): how far a sample is from the
// lumen centre between two colon points that are displaced differently,
// which segment a sample is tracked in, and which way the wall pushes.
#include <algorithm>
#include <cmath>
#include <vector>

#include <gtest/gtest.h>

#include "station/model/internal.h"
#include "tests/station/model/model_test_util.h"

namespace ves::model {
namespace {

constexpr double kTolerance_m = 1e-9;

// A straight tube along +z (points 1 cm apart, lumen radius 20 mm); point 10
// is moved 10 mm sideways, point 11 stays. A sample halfway along the segment
// between them, on the line joining the two centres, lies on the lumen's
// axis. Its offset from the centre is interpolated as a vector, so it reads
// within 1 mm of zero (the lumen planes, taken over two points each way from
// the current positions, tilt plane 11 a little toward the moved point: 0.85
// mm). Blending the two in-plane distances (10 mm and 0 mm) instead would put
// it 5 mm off the axis.
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
  EXPECT_NEAR(hit.t, 0.5, 0.05);
  EXPECT_NEAR(hit.penetration_m, scope_radius_m - 0.02, 0.001);

  // 3 mm off that axis along plane_v: the offset is 3 mm.
  const Eigen::Vector3d off_axis = on_axis + 0.003 * point.plane_v;
  const internal::SegmentHit off = internal::CalcSegmentHit(params, state, k, off_axis);
  EXPECT_NEAR(off.penetration_m, 0.003 + scope_radius_m - 0.02, 0.001);
  EXPECT_GT(off.normal.dot(point.plane_v), 0.9);
}

// Tracking (docs/model.md, "Contact"): a sample changes segment only once it
// is kTrackingHysteresis_m past the plane between them, so a sample sitting on
// a plane that the colon carries back and forth keeps its segment (and the
// colon points that take its load), while a sample that moves on is followed.
TEST(ContactGeometry, ASampleChangesSegmentOnlyOnceClearlyPastThePlane) {
  ModelParams params;
  params.colon = testing::MakeStraightTube(0.5, 0.01, 0.02, TissueParams{});
  const ModelState state = MakeInitialState(params);
  const int window = params.contact_search_window;
  const ColonPoint& plane = params.colon.points[11];
  const Eigen::Vector3d side = 0.005 * plane.plane_u;  // 5 mm off the axis
  const auto at = [&](double past_plane_m) {
    return Eigen::Vector3d(plane.rest_position_m + side + past_plane_m * state.colon_tangent[11]);
  };
  const double h = internal::kTrackingHysteresis_m;
  SampleContact c;
  c.segment = 10;
  for (int i = 0; i < 10; ++i) {  // on the plane, back and forth
    internal::TrackSegment(state, window, at(i % 2 == 0 ? 0.5 * h : -0.5 * h), &c);
    EXPECT_EQ(c.segment, 10) << "step " << i;
  }
  // Within the margin the sample is measured in the plane it is past: on a
  // straight tube the hit from either segment is the same.
  const internal::SegmentHit kept = internal::CalcSegmentHit(params, state, 10, at(0.5 * h));
  const internal::SegmentHit next = internal::CalcSegmentHit(params, state, 11, at(0.5 * h));
  EXPECT_EQ(kept.t, 1.0);
  EXPECT_NEAR(kept.penetration_m, next.penetration_m, kTolerance_m);
  EXPECT_NEAR(kept.normal.dot(next.normal), 1.0, kTolerance_m);

  internal::TrackSegment(state, window, at(2.0 * h), &c);
  EXPECT_EQ(c.segment, 11);
  internal::TrackSegment(state, window, at(-0.5 * h), &c);
  EXPECT_EQ(c.segment, 11);
  internal::TrackSegment(state, window, at(-2.0 * h), &c);
  EXPECT_EQ(c.segment, 10);
  // A sample that moved on three segments is followed in one call.
  internal::TrackSegment(state, window, at(0.03 + 0.5 * 0.01), &c);
  EXPECT_EQ(c.segment, 14);
}

// The wall presses on the scope's side, so across its axis (docs/model.md,
// "Contact"): pushed round a tight bend in a wide lumen, the scope cuts the
// corner askew to the lumen's planes. With the offset's own direction some
// contacts there would push partly along the shaft (checked below, so the
// geometry does exercise it); across the scope none does but the tip's.
TEST(ContactGeometry, TheWallPushesAcrossTheScopesSideWhereItCrossesTheLumenAskew) {
  const auto largest_axial_part = [](bool across) {
    ModelParams params;
    params.colon = testing::MakeBendTube(0.05, 1.6, 0.04, 0.25, 0.005, 0.02,
                                         testing::RigidTissue(0.1, 0.1));
    params.gravity_W_m_per_s2.setZero();
    params.contacts_across_scope = across;
    testing::Sim sim(params);
    const int tip_sample = static_cast<int>(sim.state.samples.size()) - 1;
    double largest = 0.0;
    int side_contacts = 0;
    while (sim.state.time_s < 4.0) {
      // The contacts are evaluated on the shapes at the start of the step.
      const std::vector<Eigen::Isometry3d> links_before = sim.state.X_WLink;
      StepInput in;
      in.insertion_m = 0.06 * sim.state.time_s;
      sim.StepOnce(in);
      if (!sim.out.finite) break;
      for (int j = 0; j < sim.out.contact_count; ++j) {
        const Contact& c = sim.out.contacts[j];
        if (c.sample == tip_sample) continue;  // the tip has an end face
        const Eigen::Vector3d axis = links_before[sim.state.samples[c.sample].link].linear().col(2);
        largest = std::max(largest, std::abs(c.normal_W.dot(axis)));
        ++side_contacts;
      }
    }
    EXPECT_TRUE(sim.out.finite);
    EXPECT_GT(side_contacts, 100);
    return largest;
  };
  EXPECT_LT(largest_axial_part(true), 1e-9);
  EXPECT_GT(largest_axial_part(false), 0.05);
}

// The lumen planes' normals are kept for the step (internal::LumenPlanes,
// docs/model.md, "Time step"): read through the cache they are the ones
// computed afresh, and a cache made again after the colon moved forgets the
// old ones (a stale plane would measure every sample there against where
// the colon was).
TEST(ContactGeometry, CachedLumenPlanesAreTheCurrentOnes) {
  ModelParams params;
  params.colon = testing::MakeStraightTube(0.5, 0.01, 0.02, TissueParams{});
  ModelState state = MakeInitialState(params);
  Scratch scratch = MakeScratch(params);
  const int k = 10;
  {
    internal::LumenPlanes cached(state, &scratch);
    internal::LumenPlanes fresh(state);
    for (int i = k - 3; i <= k + 3; ++i) {
      const Eigen::Vector3d first = cached.Normal(i);
      EXPECT_EQ(first, fresh.Normal(i)) << "point " << i;
      EXPECT_EQ(cached.Normal(i), first) << "point " << i << ", read again";
    }
  }
  // Point k+1 moves 10 mm sideways: the planes of k-1..k+3 tilt.
  const ColonPoint& moved = params.colon.points[k + 1];
  state.colon_displacement_m[k + 1] = 0.01 * moved.plane_u;
  state.p_WColon[k + 1] = moved.rest_position_m + state.colon_displacement_m[k + 1];
  internal::LumenPlanes cached(state, &scratch);
  internal::LumenPlanes fresh(state);
  EXPECT_LT(fresh.Normal(k).dot(state.colon_tangent[k]), 1.0 - 1e-4);  // it did tilt
  for (int i = k - 3; i <= k + 3; ++i) {
    EXPECT_EQ(cached.Normal(i), fresh.Normal(i)) << "point " << i << " after the move";
  }
}

}  // namespace
}  // namespace ves::model
