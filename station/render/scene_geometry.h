#pragma once

#include <Eigen/Geometry>
#include <vector>

namespace ves::render {

// What the views draw, in the patient frame W (docs/case-format.md: origin at
// the anus, +z cranial, +y anterior, +x toward the patient's right), metres.
// Where the scope pushes the wall outward (a model contact): around
// material arc arc_m, toward direction_W (from the lumen axis to the wall),
// by depth_m (the wall's radial deformation l, paper eq. 9).
struct WallDent {
  double arc_m{0.0};
  Eigen::Vector3d direction_W{Eigen::Vector3d::UnitX()};
  double depth_m{0.0};
};

// A plain snapshot of the deformed model (paper §3.3): segment point r_i with
// the normal of its plane P_i, the lumen radius R_i and the wall's radial
// deformation there; the scope's centreline; the tip pose for the camera.
struct SceneGeometry {
  std::vector<Eigen::Vector3d> colon_centers_m;  // r_i, anus first
  std::vector<Eigen::Vector3d> colon_tangents;   // normal of P_i (need not be unit)
  std::vector<double> colon_radius_m;            // R_i
  // Radial push-in of the wall per ring (m): the drawn radius is
  // R_i - wall_deformation_m[i]. Empty means none.
  std::vector<double> wall_deformation_m;
  // Damage level per ring for the damage display (0 = none, 1 = at the
  // threshold of harm, may exceed 1). Empty means none.
  std::vector<double> damage_level;
  // Rest arc length of each ring from the anus (m): the material coordinate
  // that anchors haustral folds and texture to the tissue as it stretches.
  // Strictly increasing. Empty means the arc length of the drawn centreline.
  std::vector<double> colon_arc_m;
  std::vector<WallDent> wall_dents;             // local outward pushes by the scope
  std::vector<Eigen::Vector3d> scope_points_m;  // insertion tube centreline, base first
  // Camera pose (station/model/model.h): at the distal tip, looking along +z
  // of the tip frame; the tip's +x is image right, its +y image up.
  Eigen::Isometry3d X_WTip{Eigen::Isometry3d::Identity()};
  double scope_diameter_m{0.013};
};

// Throws std::invalid_argument naming the first inconsistent field (sizes
// that differ, fewer than 2 rings, a non-positive radius, a zero tangent,
// a non-finite value, a colon_arc_m that does not increase).
void ValidateSceneGeometry(const SceneGeometry& scene);

}  // namespace ves::render
