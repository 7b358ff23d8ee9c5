#include "station/render/scene_geometry.h"

#include <cmath>
#include <stdexcept>
#include <string>

namespace ves::render {

void ValidateSceneGeometry(const SceneGeometry& scene) {
  const size_t n = scene.colon_centers_m.size();
  auto fail = [](const std::string& what) { throw std::invalid_argument("scene: " + what); };
  if (n < 2) fail("colon_centers_m needs at least 2 rings, has " + std::to_string(n));
  if (scene.colon_tangents.size() != n) {
    fail("colon_tangents has " + std::to_string(scene.colon_tangents.size()) + " entries, not " +
         std::to_string(n));
  }
  if (scene.colon_radius_m.size() != n) {
    fail("colon_radius_m has " + std::to_string(scene.colon_radius_m.size()) + " entries, not " +
         std::to_string(n));
  }
  if (!scene.wall_deformation_m.empty() && scene.wall_deformation_m.size() != n) {
    fail("wall_deformation_m has " + std::to_string(scene.wall_deformation_m.size()) +
         " entries, not 0 or " + std::to_string(n));
  }
  if (!scene.damage_level.empty() && scene.damage_level.size() != n) {
    fail("damage_level has " + std::to_string(scene.damage_level.size()) + " entries, not 0 or " +
         std::to_string(n));
  }
  if (!scene.colon_arc_m.empty() && scene.colon_arc_m.size() != n) {
    fail("colon_arc_m has " + std::to_string(scene.colon_arc_m.size()) + " entries, not 0 or " +
         std::to_string(n));
  }
  for (size_t i = 0; i < n; ++i) {
    if (!scene.colon_centers_m[i].allFinite())
      fail("colon_centers_m[" + std::to_string(i) + "] is not finite");
    if (!scene.colon_tangents[i].allFinite() || scene.colon_tangents[i].norm() < 1e-12) {
      fail("colon_tangents[" + std::to_string(i) + "] is zero or not finite");
    }
    if (!(scene.colon_radius_m[i] > 0.0) || !std::isfinite(scene.colon_radius_m[i])) {
      fail("colon_radius_m[" + std::to_string(i) +
           "] = " + std::to_string(scene.colon_radius_m[i]) + " is not a positive length");
    }
  }
  for (size_t i = 1; i < scene.colon_arc_m.size(); ++i) {
    if (!(scene.colon_arc_m[i] > scene.colon_arc_m[i - 1])) {
      fail("colon_arc_m must increase strictly, but [" + std::to_string(i) +
           "] = " + std::to_string(scene.colon_arc_m[i]) + " follows " +
           std::to_string(scene.colon_arc_m[i - 1]));
    }
  }
  for (size_t i = 0; i < scene.wall_dents.size(); ++i) {
    const WallDent& dent = scene.wall_dents[i];
    if (!std::isfinite(dent.arc_m) || !std::isfinite(dent.depth_m) ||
        !dent.direction_W.allFinite() || dent.direction_W.norm() < 1e-12) {
      fail("wall_dents[" + std::to_string(i) + "] is not finite or has no direction");
    }
  }
  for (size_t i = 0; i < scene.scope_points_m.size(); ++i) {
    if (!scene.scope_points_m[i].allFinite())
      fail("scope_points_m[" + std::to_string(i) + "] is not finite");
  }
  if (!scene.X_WTip.matrix().allFinite()) fail("X_WTip is not finite");
  if (!(scene.scope_diameter_m > 0.0)) {
    fail("scope_diameter_m = " + std::to_string(scene.scope_diameter_m) + " is not positive");
  }
}

}  // namespace ves::render
