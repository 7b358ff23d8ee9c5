#pragma once

// Internal pieces of Step (not part of the public API): each is O(n) or O(N)
// and allocation-free.
#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "station/model/model.h"

namespace ves::model::internal {

// (row, column) of ColonSystem::diag's entries in a block, and back.
inline constexpr int kDiagEntry[6][2] = {{0, 0}, {0, 1}, {0, 2}, {1, 1}, {1, 2}, {2, 2}};
inline constexpr int kDiagIndex[3][3] = {{0, 1, 2}, {1, 3, 4}, {2, 4, 5}};

// Rotation of the entry frame: +z along the entry axis (the anus point's rest
// tangent), +y the world's +y (anterior) made perpendicular to it.
Eigen::Matrix3d CalcEntryRotation(const ModelParams& params);

// Forward kinematics from (inserted_m, roll_rad, bend_rad): link frames, sample
// positions, tip pose and first_inside_link. Links not yet past the anus are
// straight on the entry axis (their bend is set to zero); the root link turns
// about the pivot at the anus.
void UpdateScopeKinematics(const ModelParams& params, ModelState* state);

// Turns the shaft to roll_rad about its own centreline (docs/model.md, "Roll"):
// the inserted shape stays, the link frames (and so the knobs' bending plane
// and the camera) turn with it.
void SpinScope(const ModelParams& params, double roll_rad, ModelState* state);

// Body that carries the base DOFs in the solve: the link straddling the anus.
// Its bend_rad is the pivot at the anus (its outside part stays on the entry
// axis, its inside part turns about the anus).
int RootLink(const ModelState& state);
// Length of the root link past the anus.
double CalcRootInsideLength(const ModelState& state);

// Moves each inserted sample's tracked colon segment by a local search (at most
// contact_search_window segments each way), then evaluates eqs. (9)-(17):
// per-sample force on the scope, its linearised stiffness and the contact list.
void EvaluateContacts(const ModelParams& params, const CompiledModel& model, ModelState* state,
                      Scratch* scratch, StepOutput* output);

// Ring contacts (Scratch::ring_contacts): the colon points between two
// samples' tracked segments held around the scope piece between them.
// Called by EvaluateContacts.
void EvaluateRingContacts(const ModelParams& params, ModelState* state, Scratch* scratch);

// Linearly implicit update of eq. (6) for the scope (colon held still), by an
// O(n) articulated-body recursion. Writes the new coordinates into state and
// the base reactions into output; sample displacements into scratch.
void SolveScope(const ModelParams& params, const StepInput& input, double target_insertion_m,
                ModelState* state, Scratch* scratch, StepOutput* output);

// Linearly implicit update of the colon points in 3-D (scope held at its new
// shape): suspension, mesentery, axial links, kink tension and contact
// stiffness in one block-tridiagonal solve. Writes the points' increments into
// scratch->colon_system.solution (zero for the points not solved) and updates
// their tangents.
void SolveColon(const ModelParams& params, const CompiledModel& model, const StepInput& input,
                ModelState* state, Scratch* scratch);

// Solves the symmetric positive definite block-tridiagonal system of the
// colon for points 1..last (ColonSystem: diagonal blocks diag, off-diagonal
// blocks upper) by block Thomas elimination: rhs[1..last] in, solution[1..last]
// out (its other points untouched); gain is work space. SolveColon's
// elimination, on its own so that model_bench can time it.
void SolveBlockTridiagonal(int last, ColonSystem* system);

// Step's outputs (step_outputs.cc): shares the contacts' forces onto the
// colon points and fills the per-point outputs, their peaks, the tip's arc
// (into state too) and the velocity norm, whose sum starts at sample_speed2
// (the samples' squared speeds). Returns the sum of the colon points' squared
// displacements (for the finiteness check).
double WriteStepOutputs(const ModelParams& params, const CompiledModel& model,
                        double sample_speed2, ModelState* state, const Scratch* scratch,
                        StepOutput* output);

// Recomputes the current tangents of points from..to (central differences).
void UpdateColonTangents(int from, int to, ModelState* state);

// After points from..to have moved: recomputes their tether distances and
// the lengths of the gaps on either side of them (ModelState::colon_gap_m,
// colon_tether_distance_m).
void UpdateColonDerived(const ModelParams& params, int from, int to, ModelState* state);

// The lumen's planes through the colon's current points: their normals, the
// tube's direction over two points each way (contact.cc says why). With a
// cache (EvaluateContacts) each normal is computed once, when first read,
// while the points stay where they are: a sample's tracking and its hit read
// four, and neighbouring samples read mostly the same ones.
class LumenPlanes {
 public:
  explicit LumenPlanes(const ModelState& state) : state_(state) {}
  // Caches in scratch (sized by MakeScratch), forgetting what it held there.
  LumenPlanes(const ModelState& state, Scratch* cache);
  Eigen::Vector3d Normal(int point);
  const ModelState& state() const { return state_; }

 private:
  const ModelState& state_;
  Eigen::Vector3d* normal_{nullptr};
  std::uint8_t* known_{nullptr};
};

// Moves a sample's tracked segment toward p by at most `window` segments,
// plane by plane (the lumen planes of CalcSegmentHit); it crosses a
// plane only once p is kTrackingHysteresis_m past it (contact.cc says why).
constexpr double kTrackingHysteresis_m = 0.001;
void TrackSegment(LumenPlanes* planes, int window, const Eigen::Vector3d& p,
                  SampleContact* contact);
inline void TrackSegment(const ModelState& state, int window, const Eigen::Vector3d& p,
                         SampleContact* contact) {
  LumenPlanes planes(state);
  TrackSegment(&planes, window, p, contact);
}

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
  bool end_cap{false};           // the closed end past the deepest point
};
SegmentHit CalcSegmentHit(const ModelParams& params, LumenPlanes* planes, int segment,
                          const Eigen::Vector3d& p_W);
inline SegmentHit CalcSegmentHit(const ModelParams& params, const ModelState& state, int segment,
                                 const Eigen::Vector3d& p_W) {
  LumenPlanes planes(state);
  return CalcSegmentHit(params, &planes, segment, p_W);
}

}  // namespace ves::model::internal
