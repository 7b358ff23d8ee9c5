#include "station/render/model_scene.h"

#include <algorithm>

namespace ves::render {

void FillSceneFromModel(const model::ModelParams& params, const model::ModelState& state,
                        const model::StepOutput* output, const DamageScale& damage,
                        SceneGeometry* scene) {
  const auto& points = params.colon.points;
  const size_t n = points.size();
  scene->colon_centers_m.resize(n);
  scene->colon_tangents.resize(n);
  scene->colon_radius_m.resize(n);
  scene->colon_arc_m.resize(n);
  for (size_t i = 0; i < n; ++i) {
    scene->colon_centers_m[i] =
        i < state.p_WColon.size() ? state.p_WColon[i] : points[i].rest_position_m;
    // The tube's current direction: the rings follow a pleated or looped colon.
    scene->colon_tangents[i] =
        i < state.colon_tangent.size() ? state.colon_tangent[i] : points[i].rest_tangent;
    scene->colon_radius_m[i] = points[i].radius_m;
    scene->colon_arc_m[i] = points[i].arc_m;
  }
  // The model's wall deformation pushes the wall outward where the scope
  // presses: drawn as dents from the contacts, not as a narrower ring.
  scene->wall_deformation_m.clear();
  scene->wall_dents.clear();
  scene->damage_level.clear();
  if (output != nullptr) {
    for (int c = 0; c < output->contact_count && c < static_cast<int>(output->contacts.size());
         ++c) {
      const model::Contact& contact = output->contacts[c];
      if (contact.penetration_m <= 0.0 || contact.normal_W.norm() < 1e-9) continue;
      scene->wall_dents.push_back({contact.colon_arc_m, contact.normal_W, contact.penetration_m});
    }
    scene->damage_level.assign(n, 0.0);
    for (size_t i = 0; i < n; ++i) {
      double level = 0.0;
      if (i < output->wall_force_N.size() && damage.damage_wall_force_N > 0.0) {
        level = std::max(level, output->wall_force_N[i] / damage.damage_wall_force_N);
      }
      if (i < output->stretch_m.size() && damage.damage_stretch_m > 0.0) {
        level = std::max(level, output->stretch_m[i] / damage.damage_stretch_m);
      }
      scene->damage_level[i] = level;
    }
  }
  scene->scope_points_m.clear();
  for (const Eigen::Isometry3d& X_WLink : state.X_WLink) {
    scene->scope_points_m.push_back(X_WLink.translation());
  }
  scene->scope_points_m.push_back(state.X_WTip.translation());
  scene->X_WTip = state.X_WTip;
  scene->scope_diameter_m = params.scope.outer_diameter_m;
}

}  // namespace ves::render
