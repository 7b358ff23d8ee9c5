#pragma once

// Internal pieces of Step (not part of the public API): each is O(n) or O(N)
// and allocation-free.
#include <Eigen/Core>

#include "station/model/model.h"

namespace ves::model::internal {

// Rotation of the entry frame: +z along the entry axis (the anus point's rest
// tangent), +y the world's +y (anterior) made perpendicular to it.
Eigen::Matrix3d CalcEntryRotation(const ModelParams& params);

// Forward kinematics from (inserted_m, roll_rad, bend_rad): link frames, sample
// positions, tip pose and first_inside_link. Links not yet past the anus are
// straight on the entry axis; their bend is set to zero.
void UpdateScopeKinematics(const ModelParams& params, ModelState* state);

// Body that carries the base DOFs in the solve: the link straddling the anus.
int RootLink(const ModelState& state);

// Moves each inserted sample's tracked colon segment by a local search (at most
// contact_search_window segments each way), then evaluates eqs. (9)-(17):
// per-sample force on the scope, its linearised stiffness and the contact list.
void EvaluateContacts(const ModelParams& params, ModelState* state, Scratch* scratch,
                      StepOutput* output);

// Linearly implicit update of eq. (6) for the scope (colon held still), by an
// O(n) articulated-body recursion. Writes the new coordinates into state and
// the base reactions into output; sample displacements into scratch.
void SolveScope(const ModelParams& params, const StepInput& input, double target_insertion_m,
                ModelState* state, Scratch* scratch, StepOutput* output);

// Fills the constant parts of the colon system in scratch (MakeScratch).
void PrepareColonSystem(const ModelParams& params, Scratch* scratch);

// Linearly implicit update of the colon points (scope held at its new shape):
// suspension, neighbour coupling and contact stiffness in one block-tridiagonal
// solve. Writes the colon point displacements into scratch->colon_rhs.
void SolveColon(const ModelParams& params, ModelState* state, Scratch* scratch);

// Moves a sample's tracked segment toward p by at most `window` segments.
void TrackSegment(const ModelState& state, const ColonSpec& colon, int window,
                  const Eigen::Vector3d& p, SampleContact* contact);

// Normal force of the radial wall for a penetration l (eqs. 9, 10) and its slope.
struct WallResponse {
  double force_N{0.0};
  double slope_N_per_m{0.0};
  bool beyond_threshold{false};
};
WallResponse CalcWallResponse(const TissueParams& tissue, double hardening_ratio, double l_m);

// Geometry of a sample against its tracked segment [k, k+1] of the current colon.
struct SegmentHit {
  double t{0.0};                 // 0..1 between the points
  Eigen::Vector3d normal{Eigen::Vector3d::UnitX()};  // from the lumen axis outward
  double penetration_m{-1.0};    // l: > 0 when the scope presses the wall
  double radius_m{0.0};
};
SegmentHit CalcSegmentHit(const ModelParams& params, const ModelState& state, int segment,
                          const Eigen::Vector3d& p_W);

}  // namespace ves::model::internal
