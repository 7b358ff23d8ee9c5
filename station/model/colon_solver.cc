// Linearly implicit step of the colon points (paper §3.3, Fig. 8, and the
// shortening colon of docs/model.md). Each point r_i moves in 3-D:
//   D_c h_i r_i' = -K_c h_i P_i d_i                  (paper's suspension, in the rest plane P_i)
//                  + mesentery tether (slack within its reach, then k_m h_i)
//                  + axial links to the neighbours (stiff in tension, soft while pleating)
//                  + kink tension T toward the tube's local direction
//                  + contact forces (eqs. 9-17: normal, wall damping, friction)
// with every force linearised about the current state and taken at the end
// of the step (backward Euler). That is one symmetric block-tridiagonal
// system (3x3 blocks, positive definite: every stiffness added is), solved in
// O(N) by block Thomas elimination (block_tridiagonal.cc). Point 0 (the
// anus) is fixed.
//
// The loops over every point and every pair take four at a time (lanes.h),
// on arrays with one coordinate each (Scratch::colon_arrays,
// Scratch::colon_system, CompiledModel); they are in colon_solver_lanes.inc,
// built once per instruction set.
#include <algorithm>
#include <cmath>
#include <cstring>

#include "station/model/block_tridiagonal.h"
#include "station/model/internal.h"
#include "station/model/lanes.h"

namespace ves::model::internal {
namespace {

// Beyond a few points past the deepest contact and past every point still
// displaced or moving, the colon is at rest and stays there: no force reaches
// it but the coupling to points that are themselves at rest. The solve covers
// points 1..last only (docs/model.md, "Time step"); a point within
// kRestOffset_m of home that no contact touches is held.
constexpr double kRestOffset_m = 1e-7;
constexpr double kOneStep_s = 1e-3;  // a rate that moves a point less than that per ms is rest
constexpr int kActiveMargin = 4;     // points solved past the last disturbed one
// The wall's tension stiffness is reached over this much strain, so that a
// gap passing from folding to tension does not switch stiffness in one step.
constexpr double kTensionOnsetStrain = 0.002;

int LastActivePoint(const StepInput& input, const ModelState& s, int N) {
  // A turned patient's weight and the assistant's hand move colon the scope
  // has not reached: all of it is solved.
  bool loaded = input.patient_position != PatientPosition::kSupine;
  for (double pressure : s.abdominal_pressure_level) loaded = loaded || pressure > 0.0;
  if (loaded) return N - 1;
  int last = 0;
  const int samples = static_cast<int>(s.samples.size());
  for (int i = s.first_inside_sample; i < samples; ++i) {
    last = std::max(last, s.contact[i].segment + 1);
  }
  for (int i = N - 1; i > last; --i) {
    if (s.colon_displacement_m[i].cwiseAbs().maxCoeff() > kRestOffset_m ||
        s.colon_velocity_m_per_s[i].cwiseAbs().maxCoeff() * kOneStep_s > kRestOffset_m) {
      last = i;
      break;
    }
  }
  return std::min(N - 1, last + kActiveMargin);
}

// The stored upper triangle of D_i as a symmetric matrix, and back; a
// matrix's upper triangle added to it.
Eigen::Matrix3d LoadDiag(const ColonSystem& sys, int i) {
  Eigen::Matrix3d D;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) D(r, c) = sys.diag[kDiagIndex[r][c]][i];
  }
  return D;
}
void StoreDiag(const Eigen::Matrix3d& D, int i, ColonSystem* sys) {
  for (int e = 0; e < 6; ++e) sys->diag[e][i] = D(kDiagEntry[e][0], kDiagEntry[e][1]);
}
void AddToDiag(const Eigen::Matrix3d& add, int i, ColonSystem* sys) {
  for (int e = 0; e < 6; ++e) sys->diag[e][i] += add(kDiagEntry[e][0], kDiagEntry[e][1]);
}
void AddToUpper(const Eigen::Matrix3d& add, int i, ColonSystem* sys) {
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) sys->upper[3 * r + c][i] += add(r, c);
  }
}
void AddToRhs(const Eigen::Vector3d& add, int i, ColonSystem* sys) {
  for (int c = 0; c < 3; ++c) sys->rhs[c][i] += add[c];
}

// Gravity in the patient frame with the patient in `position`, less
// gravity supine (ModelParams::gravity_W_m_per_s2): lying on the left side
// (+x is the patient's right) gravity points to -x.
Eigen::Vector3d GravityChangeFromSupine(const ModelParams& params, PatientPosition position) {
  const double g = params.gravity_W_m_per_s2.norm();
  const Eigen::Vector3d turned =
      position == PatientPosition::kLeftLateral    ? Eigen::Vector3d(-g, 0.0, 0.0)
      : position == PatientPosition::kRightLateral ? Eigen::Vector3d(g, 0.0, 0.0)
                                                   : params.gravity_W_m_per_s2;
  return turned - params.gravity_W_m_per_s2;
}

// The terms of point i's own that few points have at a time: the body wall
// behind its mesentery's root, the assistant's hand and the abdomen's walls
// (added after its suspension and tether, in that order).
void AddOwnExtraTerms(const ModelParams& params, const StepInput& input, const ModelState& s, int i,
                      ColonSystem* sys) {
  const ColonPoint& p = params.colon.points[i];
  const double dt = params.dt_s;
  const Eigen::Matrix3d I = Eigen::Matrix3d::Identity();
  const Eigen::Vector3d& x = s.p_WColon[i];
  Eigen::Matrix3d diag = LoadDiag(*sys, i);  // only its upper triangle is kept
  Eigen::Vector3d rhs = sys->Rhs(i);
  const Eigen::Vector3d r = x - p.tether_anchor_m;
  // The colon hangs on one side of its root: swung through it by more
  // than mesentery_crossing_m, it meets the body wall behind the root.
  const double crossed_m = -(r.dot(p.tether_side) + params.colon.mesentery_crossing_m);
  if (crossed_m > 0.0 && p.tether_side.squaredNorm() > 0.5) {
    const double k = params.colon.root_wall_stiffness_N_per_m2 * p.length_m;
    rhs += (dt * k * crossed_m) * p.tether_side;
    diag += (dt * k) * p.tether_side * p.tether_side.transpose();
  }
  // The assistant's hand: a pressed mobile point is held within the slack
  // of its root (isotropic; the same implicit form as the tether).
  const double pressure = s.abdominal_pressure_level[static_cast<int>(p.region)];
  if (pressure > 0.0 && p.tissue.mobile) {
    const double d = r.norm();
    const double slack = params.abdominal_pressure_slack_m;
    if (d > slack) {
      const double k = pressure * params.abdominal_pressure_stiffness_N_per_m2 * p.length_m;
      const Eigen::Vector3d g = r / d;
      rhs -= (dt * k * (d - slack)) * g;
      diag += (dt * k) * (g * g.transpose() + (1.0 - slack / d) * (I - g * g.transpose()));
    }
  }
  // The patient turned from supine: the mobile colon's weight changes
  // direction (explicit: a constant load).
  if (input.patient_position != PatientPosition::kSupine && p.tissue.mobile) {
    rhs += (dt * params.colon_linear_mass_kg_per_m * p.length_m) *
           GravityChangeFromSupine(params, input.patient_position);
  }
  // The abdominal cavity (ColonSpec::abdomen_*): a wall on each face.
  for (int axis = 0; axis < 3; ++axis) {
    const double below_m = params.colon.abdomen_min_m[axis] - x[axis];
    const double above_m = x[axis] - params.colon.abdomen_max_m[axis];
    const double out_m = below_m > 0.0 ? below_m : (above_m > 0.0 ? -above_m : 0.0);
    if (out_m == 0.0) continue;
    const double k = params.colon.root_wall_stiffness_N_per_m2 * p.length_m;
    rhs[axis] += dt * k * out_m;
    diag(axis, axis) += dt * k;
  }
  StoreDiag(diag, i, sys);
  for (int c = 0; c < 3; ++c) sys->rhs[c][i] = rhs[c];
}

}  // namespace

// The loops that take four points at a time (colon_solver_lanes.inc) are
// built twice, for AVX2 and for the baseline x86-64, and the one the CPU runs
// is chosen when the program loads (function multiversioning, as for the
// elimination's sweep in block_tridiagonal.cc; outside the anonymous
// namespace for the same reason). No function takes or returns Lanes: the
// two builds would pass them differently (Clang refuses it), so these are
// macros. A lane function ends with no call either: GCC 12 leaves the AVX
// registers' upper halves in use before such a tail call (no vzeroupper),
// and every SSE instruction after it, the elimination's among them, then
// runs about 2.4 times slower on the project's VM. VES_MODEL_BASELINE_ONLY builds the baseline alone (and the
// elimination's scalar sweep), to check on a CPU with AVX2 that it gives the
// same bits.
//
// Square roots (VES_SQRT) are correctly rounded, as std::sqrt's, in every
// build, so the builds differ only in speed: with AVX2 four lanes are one
// instruction, on the baseline two SSE2 ones. On the project's VM (AMD
// EPYC) a four-lane square root takes as long as a two-lane one (2.2 ns
// each, one after another in a loop; docs/model.md, "Speed").
#if defined(__x86_64__)
#define VES_SQRT_SSE2(v)                                            \
  ({                                                                \
    const Lanes ves_sqrt_in = (v);                                  \
    __m128d ves_sqrt_half[2];                                       \
    std::memcpy(ves_sqrt_half, &ves_sqrt_in, sizeof ves_sqrt_in);   \
    ves_sqrt_half[0] = _mm_sqrt_pd(ves_sqrt_half[0]);               \
    ves_sqrt_half[1] = _mm_sqrt_pd(ves_sqrt_half[1]);               \
    Lanes ves_sqrt_out;                                             \
    std::memcpy(&ves_sqrt_out, ves_sqrt_half, sizeof ves_sqrt_out); \
    ves_sqrt_out;                                                   \
  })
#endif
namespace lanes {
#if defined(__x86_64__) && !defined(VES_MODEL_BASELINE_ONLY)
#define VES_LANE_FUNCTION [[gnu::target("avx2")]]
#define VES_SQRT(v) ((Lanes)_mm256_sqrt_pd((__m256d)(v)))
#include "station/model/colon_solver_lanes.inc"
#undef VES_LANE_FUNCTION
#undef VES_SQRT
#define VES_LANE_FUNCTION [[gnu::target("default")]]
#define VES_SQRT(v) VES_SQRT_SSE2(v)
#include "station/model/colon_solver_lanes.inc"
#elif defined(__x86_64__)
#define VES_LANE_FUNCTION
#define VES_SQRT(v) VES_SQRT_SSE2(v)
#include "station/model/colon_solver_lanes.inc"
#else
#define VES_LANE_FUNCTION
#define VES_SQRT(v) \
  (Lanes{std::sqrt((v)[0]), std::sqrt((v)[1]), std::sqrt((v)[2]), std::sqrt((v)[3])})
#include "station/model/colon_solver_lanes.inc"
#endif
#undef VES_LANE_FUNCTION
#undef VES_SQRT
}  // namespace lanes

namespace {

// The colon's state, one array per coordinate, for points 0..end (the
// positions one further: the last tangent taken after the solve needs it).
void CopyColonState(const ModelState& s, int end, ColonSolverArrays* a) {
  const int N = static_cast<int>(s.p_WColon.size());
  lanes::SplitCoordinates(s.p_WColon, 0, std::min(end + 1, N - 1), &a->position_m);
  lanes::SplitCoordinates(s.colon_reference_m, 0, end, &a->reference_m);
  lanes::SplitCoordinates(s.colon_tangent, 0, end, &a->tangent);
  const auto copy = [end](const std::vector<double>& from, std::vector<double>* to, int at) {
    std::copy(from.begin(), from.begin() + end + 1, to->begin() + at);
  };
  copy(s.colon_gap_m, &a->gap_m, 1);
  copy(s.colon_pair_rest_gap_m, &a->rest_gap_m, 0);
  copy(s.colon_tether_distance_m, &a->tether_distance_m, 0);
}

// Contacts: the scope (at its new shape) presses the wall outward along n;
// the wall's friction reaction is the opposite of the scope's friction, in
// every direction (along the scope it drags the colon: pleating). Eqs. (9),
// (16), (17) from the colon's side.
void AddSampleContactTerms(const ModelParams& params, const ModelState& s, int last,
                           Scratch* sc) {
  const auto& pts = params.colon.points;
  const double dt = params.dt_s;
  ColonSystem& sys = sc->colon_system;
  const Eigen::Matrix3d I = Eigen::Matrix3d::Identity();
  const int samples = static_cast<int>(s.samples.size());
  for (int i = s.first_inside_sample; i < samples; ++i) {
    const SampleContact& c = s.contact[i];
    if (!c.touching) continue;
    const int k = c.segment;
    // The penetration at the scope's new shape, to first order in the
    // sample's move during the scope solve (micrometres per step): it changes
    // by n . dp; the normal and the position along the segment are kept.
    const Eigen::Vector3d& normal = sc->sample_normal_W[i];
    const double penetration_m =
        c.penetration_m + normal.dot(s.p_WSample[i] - sc->sample_delta_m[i]);
    const double t = c.segment_t;
    const TissueParams& tissue = pts[t < 0.5 ? k : k + 1].tissue;
    WallResponse r = CalcWallResponse(tissue, params.wall_hardening_ratio, penetration_m);
    if (!(penetration_m > 0.0)) {
      // The scope has just moved off this wall: keep the contact's linear
      // spring for the rest of the step, so the point follows the scope back
      // instead of springing into it (an on/off cycle between the two solves).
      r.slope_N_per_m = sc->sample_normal_slope_N_per_m[i];
      r.force_N = r.slope_N_per_m * penetration_m;
    }
    const Eigen::Vector3d f_wall = r.force_N * normal - sc->sample_friction_W_N[i];
    // The wall force falls as the points follow the scope (d f / d r = -slope
    // n n^T), the wall damping D_d (eq. 9) and the friction stick spring act on
    // the relative motion from this side too; all implicit, otherwise a light
    // colon point jumps by the whole force in one step and chatters.
    const double a = dt * r.slope_N_per_m + tissue.wall_damping_N_s_per_m;
    const double b = dt * params.friction_stiffness_N_per_m;
    const Eigen::Matrix3d K3 = b * I + (a - b) * normal * normal.transpose();
    const double w0 = 1.0 - t, w1 = t;
    if (k >= 1 && k <= last) {
      AddToRhs((dt * w0) * f_wall, k, &sys);
      AddToDiag((w0 * w0) * K3, k, &sys);
    }
    if (k + 1 <= last) {
      AddToRhs((dt * w1) * f_wall, k + 1, &sys);
      AddToDiag((w1 * w1) * K3, k + 1, &sys);
      if (k >= 1) AddToUpper((w0 * w1) * K3, k, &sys);
    }
  }
}

// Ring contacts: the scope piece pulls the ring's centre toward it (its
// penetration taken to first order in the piece's move, like the samples').
void AddRingContactTerms(const ModelParams& params, const ModelState& s, int last, Scratch* sc) {
  const auto& pts = params.colon.points;
  const double dt = params.dt_s;
  ColonSystem& sys = sc->colon_system;
  for (int j = 0; j < sc->ring_contact_count; ++j) {
    const RingContact& rc = sc->ring_contacts[j];
    const int m = rc.point;
    if (m < 1 || m > last) continue;
    const Eigen::Vector3d moved =
        (1.0 - rc.piece_t) * (s.p_WSample[rc.sample] - sc->sample_delta_m[rc.sample]) +
        rc.piece_t * (s.p_WSample[rc.sample + 1] - sc->sample_delta_m[rc.sample + 1]);
    const double penetration_m = rc.penetration_m + rc.normal_W.dot(moved);
    const double force_N = penetration_m > 0.0
                               ? rc.onset * CalcWallResponse(pts[m].tissue, params.wall_hardening_ratio,
                                                             penetration_m).force_N
                               : rc.slope_N_per_m * penetration_m;
    const double a = dt * rc.slope_N_per_m + rc.onset * pts[m].tissue.wall_damping_N_s_per_m;
    AddToRhs((dt * force_N) * rc.normal_W, m, &sys);
    const Eigen::Matrix3d K = a * rc.normal_W * rc.normal_W.transpose();
    AddToDiag(K, m, &sys);
  }
}

// The elimination, then the back substitution with each point moved as
// soon as its increment is known: the substitution is a chain of
// dependent operations, and the moves fill the time it leaves idle.
void SolveAndMovePoints(const ModelParams& params, const CompiledModel& model, int last,
                        ModelState* s, Scratch* sc) {
  ColonSystem& sys = sc->colon_system;
  EliminateForward(last, &sys);
  const double inv_dt = 1.0 / params.dt_s;
  ColonSolverArrays& arrays = sc->colon_arrays;
  Eigen::Vector3d dx = sys.Solution(last);
  for (int i = last; i >= 1; --i) {
    if (i < last) dx = SubstituteBack(i, dx, &sys);
    s->colon_displacement_m[i] += dx;
    s->colon_velocity_m_per_s[i] = dx * inv_dt;
    s->p_WColon[i] = model.rest_position_m[i] + s->colon_displacement_m[i];
    // The suspension's reference settles toward where the point is.
    const double relax = model.relax_factor[i];
    if (relax > 0.0) s->colon_reference_m[i] += relax * (s->p_WColon[i] - s->colon_reference_m[i]);
    for (int c = 0; c < 3; ++c) arrays.position_m[c][i] = s->p_WColon[i][c];
  }
}

// Folds set where a gap is held shortened, and release slowly elsewhere
// (ModelParams::colon_pleat_set_s, colon_pleat_release_s).
void SetFolds(const ModelParams& params, const CompiledModel& model, int last, ModelState* s) {
  const int N = static_cast<int>(params.colon.points.size());
  const double dt = params.dt_s;
  const double set = dt / (params.colon_pleat_set_s + dt);
  const double release = dt / (params.colon_pleat_release_s + dt);
  for (int i = 0; i < std::min(last + 1, N - 1); ++i) {
    const double g = s->colon_gap_m[i];
    double& rest_m = s->colon_pair_rest_gap_m[i];
    const double natural_m = model.pair_gap_m[i];
    if (g < rest_m) {
      const double floor_m = model.pair_pleat_limit[i] * natural_m;
      rest_m += set * (std::max(g, floor_m) - rest_m);
    } else if (rest_m < natural_m) {
      rest_m += release * (natural_m - rest_m);
    }
  }
}

// Where folds have set, the lumen gathers onto the scope
// (ModelExperiments::lumen_gather_pleat). It follows the set folds, which
// change over colon_pleat_set_s, so the wall closes in gradually.
void GatherLumen(const ModelParams& params, const CompiledModel& model, int last, ModelState* s) {
  const auto& pts = params.colon.points;
  const int N = static_cast<int>(pts.size());
  const double hug_m =
      0.5 * params.scope.outer_diameter_m + model.experiments.lumen_gather_clearance_m;
  const double g = model.experiments.lumen_gather_pleat;
  for (int i = 0; i <= std::min(last + 1, N - 1); ++i) {
    const int a = std::max(i - 1, 0), b = std::min(i, N - 2);
    const double set_ratio = (s->colon_pair_rest_gap_m[a] + s->colon_pair_rest_gap_m[b]) /
                             (model.pair_gap_m[a] + model.pair_gap_m[b]);
    const double open = std::clamp((set_ratio - g) / (1.0 - g), 0.0, 1.0);
    const double R = pts[i].radius_m;
    s->colon_lumen_radius_m[i] = R > hug_m ? hug_m + open * (R - hug_m) : R;
  }
}

}  // namespace

void UpdateColonDerived(const ModelParams& params, int from, int to, ModelState* s) {
  const auto& pts = params.colon.points;
  const int N = static_cast<int>(pts.size());
  const double shear_ratio = params.colon.mesentery_shear_ratio;
  for (int i = std::max(from, 0); i <= std::min(to, N - 1); ++i) {
    s->colon_tether_distance_m[i] = CalcTetherDistance(
        s->p_WColon[i] - pts[i].tether_anchor_m, pts[i].tether_root_direction, shear_ratio);
  }
  for (int i = std::max(from - 1, 0); i <= std::min(to, N - 2); ++i) {
    s->colon_gap_m[i] = (s->p_WColon[i + 1] - s->p_WColon[i]).norm();
  }
}

void UpdateColonTangents(int from, int to, ModelState* s) {
  const int N = static_cast<int>(s->p_WColon.size());
  for (int i = std::max(from, 0); i <= std::min(to, N - 1); ++i) {
    const Eigen::Vector3d chord = s->p_WColon[std::min(i + 1, N - 1)] - s->p_WColon[std::max(i - 1, 0)];
    const double length = chord.norm();
    if (length > 1e-12) s->colon_tangent[i] = chord / length;
  }
}

// flatten: at -O2 GCC leaves Eigen's small products out of line, and their
// calls would be a large part of the solve (docs/model.md, "Speed").
[[gnu::flatten]] void SolveColon(const ModelParams& params, const CompiledModel& model,
                                 const StepInput& input, ModelState* s, Scratch* sc) {
  const int N = static_cast<int>(params.colon.points.size());
  ColonSystem& sys = sc->colon_system;
  const int last = LastActivePoint(input, *s, N);
  const int end = std::min(last + 1, N - 1);  // first point past the solved ones (or the last)

  CopyColonState(*s, end, &sc->colon_arrays);
  // Each point's own terms: damping, the paper's suspension in its rest plane,
  // the mesentery tether and the walls.
  lanes::AddOwnTerms(params, model, input, *s, end, sc);
  // Neighbour pairs (i, i+1): the axial link and the kink tension.
  lanes::CalcPairTerms(params, model, end, sc);
  lanes::AddPairTerms(end, sc);
  AddSampleContactTerms(params, *s, last, sc);
  AddRingContactTerms(params, *s, last, sc);
  SolveAndMovePoints(params, model, last, s, sc);
  // UpdateColonDerived(params, 1, last, s), four points at a time (and
  // UpdateColonTangents(0, last + 1, s) at the end).
  ColonSolverArrays& arrays = sc->colon_arrays;
  const int last_gap = std::min(last, N - 2);
  const int tangents_to = std::min(last + 1, N - 1);
  const int inner_tangents_to = std::min(tangents_to, N - 2);
  lanes::CalcSolvedDistances(params, model, last, last_gap, sc);
  std::copy(arrays.tether_distance_m.begin() + 1, arrays.tether_distance_m.begin() + last + 1,
            s->colon_tether_distance_m.begin() + 1);
  std::copy(arrays.gap_m.begin() + 1, arrays.gap_m.begin() + last_gap + 2, s->colon_gap_m.begin());
  if (params.colon_pleat_set_s > 0.0) SetFolds(params, model, last, s);
  if (model.experiments.lumen_gather_pleat > 0.0) GatherLumen(params, model, last, s);
  std::fill(sys.solution.begin(), sys.solution.begin() + 4, 0.0);
  std::fill(sys.solution.begin() + 4 * (last + 1), sys.solution.begin() + 4 * N, 0.0);
  for (int i = last + 1; i < N; ++i) s->colon_velocity_m_per_s[i].setZero();
  // The tangents: the inner points four at a time, the ends by
  // UpdateColonTangents itself.
  lanes::CalcSolvedTangents(inner_tangents_to, sc);
  UpdateColonTangents(0, 0, s);
  for (int i = 1; i <= inner_tangents_to; ++i) {
    s->colon_tangent[i] =
        Eigen::Vector3d(arrays.tangent[0][i], arrays.tangent[1][i], arrays.tangent[2][i]);
  }
  if (tangents_to == N - 1) UpdateColonTangents(N - 1, N - 1, s);
}

}  // namespace ves::model::internal
