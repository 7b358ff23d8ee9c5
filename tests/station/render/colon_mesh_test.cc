#include "station/render/colon_mesh.h"

#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>

#include "station/render/cecum_landmarks.h"
#include "tests/station/render/test_scenes.h"

namespace ves::render {
namespace {

constexpr double kLengthTolerance_m = 1e-6;  // float vertex storage of ~0.1 m values

Eigen::Vector3d Position(const ColonMesh& mesh, size_t ring, int sector) {
  const ColonVertex& v = mesh.vertices[ring * (mesh.sectors + 1) + sector];
  return Eigen::Vector3d(v.position_m[0], v.position_m[1], v.position_m[2]);
}

ColonMeshOptions NoFolds() {
  ColonMeshOptions options;
  options.fold_depth = 0.0;
  return options;
}

// Whole colon at the finest step: no window, no level of detail, and a
// plain tube: these short tubes are all cecum, whose landmarks
// (TheCecumsLandmarksShapeItsEnd) would stand in the way of their radii.
ColonMeshOptions Uniform() {
  ColonMeshOptions options = NoFolds();
  options.lod_distance_m = 0.0;
  options.ahead_m = 0.0;
  options.cecum_landmarks = false;
  return options;
}

void Build(const SceneGeometry& scene, const ColonMeshOptions& options, double tip_arc_m,
           ColonMesh* mesh) {
  std::vector<double> arc;
  CalcMaterialArcs(scene, &arc);
  BuildColonMesh(scene, arc, tip_arc_m, options, mesh);
}

TEST(ColonMesh, SparseModelRingsAreResampledOnTheFineGrid) {
  // Model rings 1 cm apart over 0.1 m, mesh step 2.5 mm: rings at
  // 0, 2.5, ..., 100 mm, 41 of them; 10 mm is model ring 1, 15 mm is 1.5.
  // The whole tube is drawn, so its end is closed by the cecal pole's 16
  // rings of vertices (TheColonsLastPointIsClosedByADome).
  const SceneGeometry scene = testing::StraightTube(0.10, 0.01);
  ColonMesh mesh;
  Build(scene, Uniform(), 0.0, &mesh);
  ASSERT_EQ(mesh.ring_centers_m.size(), 41u);
  EXPECT_EQ(mesh.vertices.size(), (41u + 16u) * 33u);
  EXPECT_EQ(mesh.triangles.size(), (40u + 16u) * 32u * 6u);
  EXPECT_NEAR(mesh.ring_index[4], 1.0, 1e-9);
  EXPECT_NEAR(mesh.ring_index[6], 1.5, 1e-9);
  EXPECT_NEAR(mesh.ring_centers_m[6].z(), 0.015, 1e-12);
}

TEST(ColonMesh, RingsThinOutWithDistanceFromTheTipOnAFixedGrid) {
  // 1 m tube with 1 mm model rings, tip at arc 0.30 m. Window [0.27, 0.65];
  // step 2.5 mm within 5 cm of the tip, 5 mm to 10 cm, 10 mm to 20 cm, then
  // 20 mm (the maximum). Every interior ring lies on a multiple of its step.
  const SceneGeometry scene = testing::StraightTube(1.0, 0.001);
  ColonMeshOptions options = NoFolds();
  ColonMesh mesh;
  Build(scene, options, 0.30, &mesh);
  const auto& arc = mesh.ring_arc_m;
  EXPECT_NEAR(arc.front(), 0.27, 1e-12);
  EXPECT_NEAR(arc.back(), 0.65, 1e-12);
  // 0.27..0.35 by 2.5 mm (33), ..0.40 by 5 mm (10), ..0.50 by 10 mm (10),
  // ..0.64 by 20 mm (7), then the window end 0.65: 61 rings instead of 381.
  EXPECT_EQ(arc.size(), 61u);
  for (size_t k = 1; k + 1 < arc.size(); ++k) {
    const double step = arc[k] - arc[k - 1];
    const double distance = arc[k - 1] - 0.30 + 1e-9;  // as RingStep rounds
    const double expected = distance < 0.05  ? 0.0025
                            : distance < 0.1 ? 0.005
                            : distance < 0.2 ? 0.01
                                             : 0.02;
    EXPECT_NEAR(step, expected, 1e-9) << "ring " << k << " at " << arc[k];
  }
  // Moving the tip 1 mm keeps the interior rings where they were.
  ColonMesh moved;
  Build(scene, options, 0.301, &moved);
  for (size_t k = 1; k + 1 < 30; ++k) EXPECT_NEAR(moved.ring_arc_m[k], arc[k], 1e-12);
}

TEST(ColonMesh, DrawnRadiusIsModelRadiusMinusWallDeformation) {
  SceneGeometry scene = testing::StraightTube(0.05, 0.005, 0.025);
  scene.wall_deformation_m.assign(scene.colon_centers_m.size(), 0.0);
  scene.wall_deformation_m[3] = 0.004;  // drawn radius 0.025 - 0.004 = 0.021
  ColonMesh mesh;
  Build(scene, Uniform(), 0.0, &mesh);
  const size_t ring3 = 6;  // arc 15 mm on the 2.5 mm grid
  ASSERT_NEAR(mesh.ring_index[ring3], 3.0, 1e-9);
  for (int j = 0; j < mesh.sectors; ++j) {
    const double r3 = (Position(mesh, ring3, j) - scene.colon_centers_m[3]).norm();
    const double r2 = (Position(mesh, ring3 - 2, j) - scene.colon_centers_m[2]).norm();
    EXPECT_NEAR(r3, 0.021, kLengthTolerance_m);
    EXPECT_NEAR(r2, 0.025, kLengthTolerance_m);
    // The ring stays in its plane P_i (normal = tangent = +z).
    EXPECT_NEAR(Position(mesh, ring3, j).z(), scene.colon_centers_m[3].z(), kLengthTolerance_m);
  }
}

TEST(ColonMesh, ScopeDentsPushTheWallOutwardLocally) {
  // A dent 5 mm deep at arc 50 mm toward sector 0: that vertex moves out to
  // R + 5 mm; the opposite side (cos < 0) and rings 3 spreads away do not.
  SceneGeometry scene = testing::StraightTube(0.1, 0.005, 0.025);
  ColonMesh plain;
  Build(scene, Uniform(), 0.0, &plain);
  const size_t ring = 20;  // arc 50 mm on the 2.5 mm grid
  const Eigen::Vector3d toward =
      (Position(plain, ring, 0) - plain.ring_centers_m[ring]).normalized();
  scene.wall_dents.push_back({0.05, toward, 0.005});
  ColonMesh dented;
  Build(scene, Uniform(), 0.0, &dented);
  const auto radius = [&](size_t k, int j) {
    return (Position(dented, k, j) - dented.ring_centers_m[k]).norm();
  };
  EXPECT_NEAR(radius(ring, 0), 0.030, kLengthTolerance_m);
  EXPECT_NEAR(radius(ring, 16), 0.025, kLengthTolerance_m);
  EXPECT_NEAR(radius(ring + 16, 0), 0.025, 1e-5);  // 40 mm away: exp(-(40/12)^2) ≈ 0
  EXPECT_NEAR(radius(ring + 4, 0), 0.0275, 1e-5);  // 10 mm away: 5 mm · exp(-(10/12)²) = 2.5 mm
}

TEST(ColonMesh, ArcNearAPointIsItsProjectionOnTheCentreline) {
  const SceneGeometry scene = testing::StraightTube(0.2, 0.005);
  std::vector<double> arc;
  CalcMaterialArcs(scene, &arc);
  EXPECT_NEAR(CalcArcNear(scene, arc, Eigen::Vector3d(0.01, -0.005, 0.0437)), 0.0437, 1e-12);
  EXPECT_NEAR(CalcArcNear(scene, arc, Eigen::Vector3d(0.0, 0.0, 0.5)), 0.2, 1e-12);
}

TEST(ColonMesh, DeformationNeverClosesTheLumen) {
  SceneGeometry scene = testing::StraightTube(0.05, 0.005, 0.02);
  scene.wall_deformation_m.assign(scene.colon_centers_m.size(), 0.05);  // more than R
  ColonMeshOptions options = Uniform();
  ColonMesh mesh;
  Build(scene, options, 0.0, &mesh);
  EXPECT_NEAR(mesh.ring_radius_m[0], options.min_radius_fraction * 0.02, 1e-12);
}

TEST(ColonMesh, HaustralFoldsNarrowTheLumenOncePerPeriod) {
  ColonMeshOptions options;
  options.fold_period_m = 0.04;
  options.fold_depth = 0.2;
  // At a ridge (s = 0) the factor is 1 - depth * (0.7 + 0.3 cos 3θ):
  // θ = 0 → 1 - 0.2 = 0.8; θ = π/3 → 1 - 0.2 * 0.4 = 0.92.
  EXPECT_NEAR(HaustralFoldFactor(options, 0.0, 0.0), 0.8, 1e-12);
  EXPECT_NEAR(HaustralFoldFactor(options, 0.0, testing::kTestPi / 3), 0.92, 1e-12);
  EXPECT_NEAR(HaustralFoldFactor(options, 0.04, 0.0), 0.8, 1e-12);  // one period on
  // Half way between ridges ((1 + cos π)/2)^8 = 0: no narrowing.
  EXPECT_NEAR(HaustralFoldFactor(options, 0.02, 0.0), 1.0, 1e-12);
  options.fold_depth = 0.0;
  EXPECT_EQ(HaustralFoldFactor(options, 0.0, 0.0), 1.0);
}

TEST(ColonMesh, FramesDoNotTwistAlongAStraightTube) {
  const SceneGeometry scene = testing::StraightTube(0.2, 0.005);
  ColonMesh mesh;
  Build(scene, Uniform(), 0.0, &mesh);
  const Eigen::Vector3d first = Position(mesh, 0, 5) - scene.colon_centers_m[0];
  const size_t last = mesh.ring_centers_m.size() - 1;
  const Eigen::Vector3d final_offset = Position(mesh, last, 5) - mesh.ring_centers_m[last];
  EXPECT_LT((first - final_offset).norm(), kLengthTolerance_m);
}

TEST(ColonMesh, NormalsOfAPlainTubeAreRadial) {
  const SceneGeometry scene = testing::StraightTube(0.1, 0.005);
  ColonMesh mesh;
  Build(scene, Uniform(), 0.0, &mesh);
  const ColonVertex& v = mesh.vertices[10 * (mesh.sectors + 1) + 7];
  const Eigen::Vector3d n(v.normal[0], v.normal[1], v.normal[2]);
  const Eigen::Vector3d radial = (Position(mesh, 10, 7) - mesh.ring_centers_m[10]).normalized();
  EXPECT_NEAR(std::abs(n.dot(radial)), 1.0, 1e-5);
}

TEST(ColonMesh, TextureFollowsTheTissueWhenTheColonStretches) {
  // Same material arc, centres twice as far apart: v must not change.
  SceneGeometry scene = testing::StraightTube(0.1, 0.005);
  scene.colon_arc_m.clear();
  for (const auto& c : scene.colon_centers_m) scene.colon_arc_m.push_back(c.z());
  SceneGeometry stretched = scene;
  for (auto& c : stretched.colon_centers_m) c *= 2.0;
  ColonMesh a;
  ColonMesh b;
  const ColonMeshOptions options = Uniform();
  Build(scene, options, 0.0, &a);
  Build(stretched, options, 0.0, &b);
  ASSERT_EQ(a.vertices.size(), b.vertices.size());
  EXPECT_FLOAT_EQ(a.vertices[500].uv[1], b.vertices[500].uv[1]);
  EXPECT_GT(a.vertices[500].uv[1], 0.0f);
}

TEST(ColonMesh, TubeMeshSurroundsThePolyline) {
  std::vector<float> positions;
  std::vector<std::uint32_t> triangles;
  BuildTubeMesh({{0, 0, 0}, {0, 0, 0.1}, {0.1, 0, 0.1}}, 0.005, 8, &positions, &triangles);
  EXPECT_EQ(positions.size(), 3u * 8u * 3u);
  EXPECT_EQ(triangles.size(), 2u * 8u * 6u);
  const Eigen::Vector3d p(positions[0], positions[1], positions[2]);
  EXPECT_NEAR(p.norm(), 0.005, kLengthTolerance_m);
  BuildTubeMesh({{0, 0, 0}}, 0.005, 8, &positions, &triangles);
  EXPECT_TRUE(positions.empty());
}

// The cecum is a blind pouch (colon_mesh.cc): a window that reaches the
// colon's last point closes the tube with a dome that ends in one point on
// the axis beyond the last ring; a window short of it leaves the tube open.
TEST(ColonMesh, TheColonsLastPointIsClosedByADome) {
  constexpr double kLength_m = 0.5, kRadius_m = 0.025;
  const SceneGeometry scene = testing::StraightTube(kLength_m, 0.005, kRadius_m);
  const ColonMeshOptions options = NoFolds();
  const size_t columns = static_cast<size_t>(options.sectors) + 1;
  ColonMesh open;
  Build(scene, options, 0.10, &open);  // drawn to 0.45 m
  EXPECT_EQ(open.vertices.size(), open.ring_centers_m.size() * columns);

  ColonMesh closed;
  Build(scene, options, 0.30, &closed);  // drawn to the end
  const size_t tube = closed.ring_centers_m.size() * columns;
  ASSERT_GT(closed.vertices.size(), tube);
  EXPECT_GT(closed.triangles.size(), (closed.ring_centers_m.size() - 1) * options.sectors * 6);
  double pole_z = 0.0;
  for (size_t i = tube; i < closed.vertices.size(); ++i) {
    const float* p = closed.vertices[i].position_m;
    EXPECT_LE(std::hypot(p[0], p[1]), kRadius_m + kLengthTolerance_m) << "vertex " << i;
    EXPECT_GE(p[2], kLength_m - kLengthTolerance_m) << "vertex " << i;
    pole_z = std::max(pole_z, static_cast<double>(p[2]));
  }
  // The last ring of the dome is its pole: one point, a real bulge ahead.
  for (size_t i = closed.vertices.size() - columns; i < closed.vertices.size(); ++i) {
    const float* p = closed.vertices[i].position_m;
    EXPECT_NEAR(std::hypot(p[0], p[1]), 0.0, kLengthTolerance_m) << "vertex " << i;
    EXPECT_NEAR(p[2], pole_z, kLengthTolerance_m) << "vertex " << i;
  }
  EXPECT_GT(pole_z, kLength_m + 0.25 * kRadius_m);
}

// The cecum a trainee can confirm (cecum_landmarks.h), as the mesh's shape:
// the triradiate fold raises the dome on the taeniae's meridians (not
// between them), the appendiceal orifice sinks the pole, and the ileocaecal
// valve's two-lipped cushion narrows the lumen on one side 3.5 cm before the pole.
TEST(ColonMesh, TheCecumsLandmarksShapeItsEnd) {
  constexpr double kLength_m = 0.5, kRadius_m = 0.025;
  const SceneGeometry scene = testing::StraightTube(kLength_m, 0.005, kRadius_m);
  ColonMeshOptions options = NoFolds();
  const size_t columns = static_cast<size_t>(options.sectors) + 1;
  ColonMesh plain;
  options.cecum_landmarks = false;
  Build(scene, options, 0.45, &plain);  // the finest rings from 0.42 m to the end
  ColonMesh marked;
  options.cecum_landmarks = true;
  Build(scene, options, 0.45, &marked);
  ASSERT_EQ(marked.vertices.size(), plain.vertices.size());
  const size_t tube = marked.ring_centers_m.size() * columns;
  const size_t dome_rows = (marked.vertices.size() - tube) / columns;
  const auto radial = [&](const ColonMesh& mesh, size_t row, size_t j) {
    const float* p = mesh.vertices[row * columns + j].position_m;
    return std::hypot(static_cast<double>(p[0]), static_cast<double>(p[1]));
  };
  // Mid-dome: j = 16 of 32 is a taenia (cos 3θ = -1 at θ = π), j = 0 between two.
  const size_t mid = marked.ring_centers_m.size() + dome_rows / 2;
  EXPECT_NEAR(radial(plain, mid, 16), radial(plain, mid, 0), kLengthTolerance_m);
  EXPECT_LT(radial(marked, mid, 16), radial(marked, mid, 0) - 0.03 * kRadius_m);
  // The pole: the orifice's pit, a fifth of the radius deeper than the plain dome.
  const float* plain_pole = plain.vertices.back().position_m;
  const float* marked_pole = marked.vertices.back().position_m;
  EXPECT_GT(marked_pole[2], plain_pole[2] + 0.2 * kRadius_m);
  // The valve: a cushion on one side 3.5 cm before the rim, standing at
  // least 8 mm out of the wall on a lip (the other side and the sides a
  // quarter turn away untouched: a bulge, not a fold round the wall), with
  // a slit between its two lips.
  size_t lip = 0, slit = 0, medial = 0;
  const auto from_pole = [&](size_t k) { return kLength_m - marked.ring_arc_m[k]; };
  for (size_t k = 0; k < marked.ring_arc_m.size(); ++k) {
    if (std::abs(from_pole(k) - kValveFromPole_m) < std::abs(from_pole(slit) - kValveFromPole_m)) {
      slit = k;
    }
    if (from_pole(k) < kValveFromPole_m || from_pole(k) > kValveReach_m) continue;
    for (size_t j = 0; j < columns; ++j) {
      EXPECT_NEAR(radial(plain, k, j), kRadius_m, kLengthTolerance_m);
      if (radial(marked, k, j) < radial(marked, lip, medial)) {
        lip = k;
        medial = j;
      }
    }
  }
  const size_t sectors = columns - 1;
  const size_t opposite = (medial + sectors / 2) % sectors;
  EXPECT_LT(radial(marked, lip, medial), radial(marked, lip, opposite) - 0.008);
  EXPECT_GT(radial(marked, lip, opposite), 0.99 * kRadius_m);
  EXPECT_GT(radial(marked, lip, (medial + sectors / 4) % sectors), 0.97 * kRadius_m);
  EXPECT_GT(radial(marked, lip, (medial + 3 * sectors / 4) % sectors), 0.97 * kRadius_m);
  EXPECT_GT(radial(marked, slit, medial), radial(marked, lip, medial) + 0.003);
  // The wireframe draws the valve's every ring and sector, the plain wall sparsely.
  EXPECT_GT(marked.lines.size(), plain.lines.size() + 20);
  // Away from the cecum the tube is the plain one.
  for (size_t j = 0; j < columns; ++j) {
    EXPECT_EQ(radial(marked, 0, j), radial(plain, 0, j));
  }
}

TEST(SceneGeometry, InconsistentScenesAreRejectedByName) {
  SceneGeometry scene = testing::StraightTube();
  EXPECT_NO_THROW(ValidateSceneGeometry(scene));
  SceneGeometry bad = scene;
  bad.colon_radius_m.pop_back();
  EXPECT_THROW(
      {
        try {
          ValidateSceneGeometry(bad);
        } catch (const std::invalid_argument& e) {
          EXPECT_NE(std::string(e.what()).find("colon_radius_m"), std::string::npos);
          throw;
        }
      },
      std::invalid_argument);
  bad = scene;
  bad.colon_tangents[4] = Eigen::Vector3d::Zero();
  EXPECT_THROW(ValidateSceneGeometry(bad), std::invalid_argument);
  bad = scene;
  bad.colon_radius_m[2] = -0.01;
  EXPECT_THROW(ValidateSceneGeometry(bad), std::invalid_argument);
  bad = scene;
  bad.damage_level = {1.0};
  EXPECT_THROW(ValidateSceneGeometry(bad), std::invalid_argument);
}

}  // namespace
}  // namespace ves::render
