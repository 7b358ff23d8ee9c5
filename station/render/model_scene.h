#pragma once

#include "station/model/model.h"
#include "station/render/scene_geometry.h"

namespace ves::render {

// What turns a segment into "damaged" on the damage display: the larger of
// wall force / damage_wall_force_N and mesentery stretch / damage_stretch_m.
// The defaults are training's MetricThresholds damage and pain levels, so the
// display marks what the session scores (ModelScene.DamageScaleIsTheScoringsDamageAndPainLevels
// checks that they stay equal).
struct DamageScale {
  double damage_wall_force_N{14.0};
  double damage_stretch_m{0.02};
};

// Fills `scene` (reusing its storage) from a model state: colon ring i at
// the deformed r_i in its rest plane P_i with radius R_i and material arc;
// the scope's contacts as outward wall dents; the scope's centreline from
// its link joints to the tip; the camera at the tip. `output` (the last
// step's) gives per-segment damage and the dents; nullptr leaves both empty.
void FillSceneFromModel(const model::ModelParams& params, const model::ModelState& state,
                        const model::StepOutput* output, const DamageScale& damage,
                        SceneGeometry* scene);

inline SceneGeometry SceneFromModel(const model::ModelParams& params,
                                    const model::ModelState& state,
                                    const model::StepOutput* output = nullptr,
                                    const DamageScale& damage = {}) {
  SceneGeometry scene;
  FillSceneFromModel(params, state, output, damage, &scene);
  return scene;
}

}  // namespace ves::render
