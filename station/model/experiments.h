#pragma once

namespace ves::model {

// Settings of the model that the product never uses: variants measured by the
// benches and probes (docs/model-shortening-notes.md) and kept so that a
// measurement can be repeated. They enter only when the model is compiled
// (CompileModel, MakeScratch); the defaults are the product's model.
struct ModelExperiments {
  // A colon whose folds have set hugs the scope: where the set pleat ratio
  // (rest gap over natural gap) falls from 1 to this value, the lumen's
  // radius falls linearly from the case's to the scope's plus
  // lumen_gather_clearance_m. 0: off (the lumen keeps the case's radius).
  // docs/model-shortening-notes.md, "A lumen that gathers onto the scope".
  double lumen_gather_pleat{0.0};
  double lumen_gather_clearance_m{1e-3};
  bool operator==(const ModelExperiments&) const = default;
};

}  // namespace ves::model
