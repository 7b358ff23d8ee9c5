#pragma once

#include <Eigen/Geometry>
#include <cmath>

#include "station/render/scene_geometry.h"

// Synthetic scenes for the render tests: no model needed.
namespace ves::render::testing {

constexpr double kTestPi = 3.14159265358979323846;

// A straight tube along +z of W from z = 0 to length_m, rings every
// spacing_m, constant radius; the tip camera on the axis at tip_z_m looking
// up the tube (+z), image right = W +x, image up = W +y; the scope along the axis
// from z = 0 to the tip.
inline SceneGeometry StraightTube(double length_m = 0.5, double spacing_m = 0.005,
                                  double radius_m = 0.025, double tip_z_m = 0.1) {
  SceneGeometry scene;
  const int rings = static_cast<int>(std::lround(length_m / spacing_m)) + 1;
  for (int i = 0; i < rings; ++i) {
    scene.colon_centers_m.emplace_back(0.0, 0.0, i * spacing_m);
    scene.colon_tangents.emplace_back(0.0, 0.0, 1.0);
    scene.colon_radius_m.push_back(radius_m);
  }
  for (int i = 0; i <= 20; ++i) scene.scope_points_m.emplace_back(0.0, 0.0, tip_z_m * i / 20.0);
  scene.X_WTip = Eigen::Isometry3d::Identity();
  scene.X_WTip.translation() = Eigen::Vector3d(0.0, 0.0, tip_z_m);
  return scene;
}

// A tube running 0.15 m up +z and then bending toward +x on a circle of
// bend_radius_m through 90°, continuing straight along +x. The camera sits
// on the axis in the straight part, 4 cm before the bend.
inline SceneGeometry BentTube(double bend_radius_m = 0.06, double spacing_m = 0.004,
                              double radius_m = 0.022) {
  SceneGeometry scene;
  auto add = [&](const Eigen::Vector3d& c, const Eigen::Vector3d& t) {
    scene.colon_centers_m.push_back(c);
    scene.colon_tangents.push_back(t);
    scene.colon_radius_m.push_back(radius_m);
  };
  const double straight_m = 0.15;
  for (double z = 0.0; z < straight_m; z += spacing_m) add({0, 0, z}, {0, 0, 1});
  const double bend_m = 0.5 * kTestPi * bend_radius_m;
  for (double s = 0.0; s < bend_m; s += spacing_m) {
    const double a = s / bend_radius_m;
    add({bend_radius_m * (1.0 - std::cos(a)), 0.0, straight_m + bend_radius_m * std::sin(a)},
        {std::sin(a), 0.0, std::cos(a)});
  }
  for (double x = bend_radius_m; x < bend_radius_m + 0.2; x += spacing_m) {
    add({x, 0.0, straight_m + bend_radius_m}, {1, 0, 0});
  }
  const double tip_z = straight_m - 0.04;
  for (int i = 0; i <= 20; ++i) scene.scope_points_m.emplace_back(0.0, 0.0, tip_z * i / 20.0);
  scene.X_WTip.translation() = Eigen::Vector3d(0.0, 0.0, tip_z);
  return scene;
}

// The tip frame turned by `angle_rad` about its own x axis (an up/down knob).
inline Eigen::Isometry3d TurnedAboutTipX(const Eigen::Isometry3d& X_WTip, double angle_rad) {
  Eigen::Isometry3d turned = X_WTip;
  turned.linear() =
      X_WTip.linear() * Eigen::AngleAxisd(angle_rad, Eigen::Vector3d::UnitX()).toRotationMatrix();
  return turned;
}

}  // namespace ves::render::testing
