#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "station/render/scene_geometry.h"

namespace ves::render {

// How the colon's rings become a surface (paper §4.2, Fig. 12(a)). The
// centreline is resampled at fixed steps of material arc length (so rings,
// folds and texture stay on the tissue while the scope moves), finely near
// the tip and coarser with distance (level of detail), only within a window
// around the tip: beyond it the light at the lens leaves the lumen black.
struct ColonMeshOptions {
  int sectors{32};                // vertices around each ring
  double ring_spacing_m{0.0025};  // finest step of mesh rings, near the tip
  // The step doubles each time the arc distance from the tip doubles beyond
  // lod_distance_m, up to max_ring_spacing_m. lod_distance_m <= 0: uniform.
  double lod_distance_m{0.05};
  double max_ring_spacing_m{0.02};
  // Window of arc length drawn around the tip; ahead_m <= 0: whole colon.
  double behind_m{0.03};
  double ahead_m{0.35};
  // Haustral folds: the radius dips at ridges every fold_period_m of arc
  // length, fold_depth of the radius deep, sharper for larger sharpness; the
  // three taeniae make the dip deepest at three angles around the wall.
  double fold_period_m{0.045};
  double fold_depth{0.22};
  double fold_sharpness{8.0};
  double texture_length_m{0.06};     // arc length one texture tile covers
  double min_radius_fraction{0.15};  // deformation never closes the lumen beyond this
  // A wall dent spreads this far along the colon (Gaussian sigma) and over
  // cos^4 of the angle from its direction around the wall.
  double dent_spread_m{0.012};
  double wire_ring_spacing_m{0.01};  // wireframe: a ring loop every this much arc
  int wire_sector_stride{2};         // wireframe: every n-th sector drawn lengthwise
  // The cecum's landmarks (cecum_landmarks.h): the ileocaecal valve, the
  // triradiate fold and the appendiceal orifice; off: a plain dome.
  bool cecum_landmarks{true};
};

// One vertex of the colon surface, as uploaded to the GPU.
struct ColonVertex {
  float position_m[3];
  float normal[3];
  float uv[2];  // u around the wall [0, 1], v = arc length / texture_length_m
  float ring;   // continuous index of the model ring the vertex lies on
};

struct ColonMesh {
  int sectors{0};
  std::vector<ColonVertex> vertices;  // mesh rings x (sectors + 1), seam duplicated
  std::vector<std::uint32_t> triangles;
  std::vector<std::uint32_t> lines;  // wireframe segments
  // Per mesh ring: centre, radius between folds (R_i minus deformation),
  // unit tangent, continuous model ring index, material arc length.
  std::vector<Eigen::Vector3d> ring_centers_m;
  std::vector<double> ring_radius_m;
  std::vector<Eigen::Vector3d> ring_tangents;
  std::vector<double> ring_index;
  std::vector<double> ring_arc_m;
};

// Radius factor of the haustral folds at arc length s and angle `angle_rad`
// around the wall: 1 between folds, 1 - fold_depth at the deepest point.
double HaustralFoldFactor(const ColonMeshOptions& options, double arc_m, double angle_rad);

// Material arc length of every model ring: scene.colon_arc_m, or the
// cumulative length of the drawn centreline when that is empty.
void CalcMaterialArcs(const SceneGeometry& scene, std::vector<double>* arc_m);

// Material arc length of the point of the centreline nearest to p_W
// (searched around the nearest ring centre).
double CalcArcNear(const SceneGeometry& scene, const std::vector<double>& arc_m,
                   const Eigen::Vector3d& p_W);

// Rebuilds `mesh` (keeping its storage) from the scene's rings around the
// tip at material arc `tip_arc_m`: each ring in its plane P_i (normal and
// centre interpolated between model rings), radius R_i minus the wall
// deformation, the scope's dents pushed outward, folds as geometry, frames carried along the
// centreline by parallel transport so the texture does not twist. The scene must be valid
// (ValidateSceneGeometry); `arc_m` from CalcMaterialArcs.
void BuildColonMesh(const SceneGeometry& scene, const std::vector<double>& arc_m, double tip_arc_m,
                    const ColonMeshOptions& options, ColonMesh* mesh);

// A closed tube of `radius_m` around a polyline (the scope for fluoroscopy):
// positions xyz-packed, triangle indices. Fewer than 2 points give nothing.
void BuildTubeMesh(const std::vector<Eigen::Vector3d>& points_m, double radius_m, int sectors,
                   std::vector<float>* positions_m, std::vector<std::uint32_t>* triangles);

// A unit vector perpendicular to `direction` (any one, chosen stably).
Eigen::Vector3d AnyPerpendicular(const Eigen::Vector3d& direction);

}  // namespace ves::render
