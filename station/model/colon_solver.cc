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
// O(N) by block Thomas elimination. Point 0 (the anus) is fixed.
//
// The loops over every point and every pair take four at a time ("lanes",
// GCC and Clang vector extensions; docs/model.md, "Speed"), on arrays with
// one coordinate each (Scratch::colon_arrays, Scratch::colon_system); they
// are in colon_solver_lanes.inc, built once per instruction set.
#include <algorithm>
#include <cmath>
#include <cstring>
#if defined(__x86_64__)
#include <immintrin.h>
#endif

#include "station/model/internal.h"

#if defined(__GNUC__) && !defined(__clang__)
// Lanes are 32 bytes; no function takes or returns them (see
// VES_LANE_FUNCTION), so GCC's note that AVX changes how they are passed
// does not apply.
#pragma GCC diagnostic ignored "-Wpsabi"
#endif

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
// A gap whose material is less than this longer than its rest gap has no
// reserve to straighten (a resampled curve's chord is a little shorter than
// its arc everywhere).
constexpr double kMinReserveStrain = 0.01;

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

// Four doubles in one value. Each lane does the scalar formula's IEEE
// operations in the scalar code's order, Eigen's included (a dot product or
// a norm sums from the first coordinate; s (u u^T) is evaluated as (s u) u^T;
// a 3x3 matrix times a vector sums its first two rows from the left and its
// third from the right), and nothing is fused into an FMA: the results are
// bit for bit those of one point at a time, in the AVX2 build and in the
// baseline one, so a replay stays exact on any x86-64.
typedef double Lanes __attribute__((vector_size(4 * sizeof(double))));
// Four doubles of an array, at any double's alignment. Not may_alias: GCC
// takes a vector of doubles to alias doubles (every array read or written
// this way holds doubles) and nothing else, so it keeps the arrays' data
// pointers in registers, which with may_alias it read again after every
// store (Clang takes any vector access to alias anything, as before).
typedef double LanesInMemory
    __attribute__((vector_size(4 * sizeof(double)), aligned(alignof(double))));
using LaneMask = decltype(Lanes{} < Lanes{});
constexpr int kLanes = 4;
// (row, column) of ColonSystem::diag's entries in a block, and back.
constexpr int kDiagEntry[6][2] = {{0, 0}, {0, 1}, {0, 2}, {1, 1}, {1, 2}, {2, 2}};
constexpr int kDiagIndex[3][3] = {{0, 1, 2}, {1, 3, 4}, {2, 4, 5}};
static_assert(kLanes <= kColonLanePadding, "the colon's arrays must hold a whole last group");

#define VES_LOAD(array, i) (Lanes(*reinterpret_cast<const LanesInMemory*>((array).data() + (i))))
#define VES_STORE_AT(pointer, value) (*reinterpret_cast<LanesInMemory*>(pointer) = (value))
#define VES_STORE(array, i, value) VES_STORE_AT((array).data() + (i), value)
// Lanes where mask is set take a, the others b.
#define VES_SELECT(mask, a, b) ((Lanes)(((mask) & (LaneMask)(a)) | (~(mask) & (LaneMask)(b))))
#define VES_ANY(mask) (((mask)[0] | (mask)[1] | (mask)[2] | (mask)[3]) != 0)

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
// is chosen when the program loads (function multiversioning, as for
// EliminateForward below; outside the anonymous namespace for the same
// reason). No function takes or returns Lanes: the two builds would pass
// them differently (Clang refuses it), so these are macros. A lane function
// ends with no call either: GCC 12 left the AVX registers' upper halves in
// use before such a tail call (no vzeroupper), and every SSE instruction
// after it, the elimination's among them, ran about 2.4 times slower on the
// project's VM. VES_MODEL_BASELINE_ONLY builds the baseline alone (and the
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

}  // namespace

void PrepareColonSystem(const ModelParams& params, Scratch* sc) {
  const auto& pts = params.colon.points;
  const int N = static_cast<int>(pts.size());
  const size_t size = static_cast<size_t>(N) + kColonLanePadding;
  ColonSolverArrays& a = sc->colon_arrays;
  for (CoordinateArrays* xyz :
       {&a.position_m, &a.reference_m, &a.tangent, &a.pair_impulse, &a.rest_tangent,
        &a.tether_anchor_m, &a.tether_root_direction, &a.tether_side}) {
    for (auto& v : *xyz) v.assign(size, 0.0);
  }
  for (auto& v : a.pair_block) v.assign(size, 0.0);
  for (auto& v : a.own_diag) v.assign(size, 0.0);
  for (std::vector<double>* v :
       {&a.rest_gap_m, &a.tether_distance_m, &a.suspension_rhs_factor, &a.has_tether_side,
        &a.tether_length_m, &a.mesentery_length_m, &a.length_m, &a.reach_gathers, &a.natural_span_m,
        &a.pair_kink_N_per_m}) {
    v->assign(size, 0.0);
  }
  a.gap_m.assign(size + 1, 0.0);
  a.mobile.assign(size, 0);
  a.rest_position_m.assign(size, Eigen::Vector3d::Zero());
  std::fill(a.rest_gap_m.begin(), a.rest_gap_m.end(), 1.0);
  std::fill(a.natural_span_m.begin(), a.natural_span_m.end(), 1.0);
  a.pair_pleat_limit.assign(size, 1.0);
  a.pair_toe_N.assign(size, params.colon_tension_stiffness_N);
  a.pair_toe_strain.assign(size, params.colon_toe_strain);
  a.inverse_material_gap.assign(size, 0.0);
  a.pair_reserve_end_m.assign(size, 0.0);
  for (CoordinateArrays* xyz : {&a.pair_rest_direction, &a.pair_rest_mean_tangent}) {
    (*xyz)[0].assign(size, 0.0);
    (*xyz)[1].assign(size, 0.0);
    (*xyz)[2].assign(size, 1.0);
  }
  sc->colon_tether_N_per_m.assign(size, 0.0);
  sc->colon_relax_factor.assign(size, 0.0);
  sc->colon_pair_gap_m.assign(size, 1.0);
  // The least rest gap over material gap times pleat limit: how much
  // material a pleated colon can pack onto a metre of scope.
  double smallest_pleat_limit = 1.0;
  const Eigen::Matrix3d I = Eigen::Matrix3d::Identity();
  for (int i = 0; i < N; ++i) {
    const ColonPoint& p = pts[i];
    const TissueParams& t = p.tissue;
    const double h = p.length_m;
    const double K_c = t.suspension_stiffness_N_per_m2 * h;
    sc->colon_tether_N_per_m[i] = t.mesentery_stiffness_N_per_m2 * h;
    const Eigen::Matrix3d P = I - p.rest_tangent * p.rest_tangent.transpose();
    const Eigen::Matrix3d own = (t.suspension_damping_N_s_per_m2 * h) * I + (params.dt_s * K_c) * P;
    for (int e = 0; e < 6; ++e) a.own_diag[e][i] = own(kDiagEntry[e][0], kDiagEntry[e][1]);
    a.suspension_rhs_factor[i] = -(params.dt_s * K_c);
    if (t.suspension_relaxation_s > 0.0) {
      sc->colon_relax_factor[i] = params.dt_s / (t.suspension_relaxation_s + params.dt_s);
    }
    for (int c = 0; c < 3; ++c) {
      a.rest_tangent[c][i] = p.rest_tangent[c];
      a.tether_anchor_m[c][i] = p.tether_anchor_m[c];
      a.tether_root_direction[c][i] = p.tether_root_direction[c];
      a.tether_side[c][i] = p.tether_side[c];
    }
    a.has_tether_side[i] = p.tether_side.squaredNorm() > 0.5 ? 1.0 : 0.0;
    a.tether_length_m[i] = p.tether_length_m;
    a.length_m[i] = p.length_m;
    a.mobile[i] = t.mobile ? 1 : 0;
    a.rest_position_m[i] = p.rest_position_m;
    a.mesentery_length_m[i] = t.mesentery_length_m;
    a.reach_gathers[i] =
        params.mesentery_reach_gathers && t.mobile && i > 0 && i < N - 1 ? 1.0 : 0.0;
  }
  const auto has_toe = [&](Region r) {
    return ((params.colon_toe_regions >> static_cast<unsigned>(r)) & 1u) != 0;
  };
  for (int i = 0; i + 1 < N; ++i) {
    const double gap = (pts[i + 1].rest_position_m - pts[i].rest_position_m).norm();
    const double T =
        0.5 * (pts[i].tissue.neighbor_tension_N + pts[i + 1].tissue.neighbor_tension_N);
    sc->colon_pair_gap_m[i] = gap;
    a.pair_kink_N_per_m[i] = T / gap;
    a.pair_pleat_limit[i] = std::min(pts[i].tissue.pleat_limit, pts[i + 1].tissue.pleat_limit);
    if (has_toe(pts[i].region) && has_toe(pts[i + 1].region)) {
      a.pair_toe_N[i] = params.colon_toe_stiffness_N;
    }
    // The gathered reserve: the gap's material length is its rest arc,
    // longer than the gathered rest gap; it straightens up to it softly.
    const double material_m = std::max(pts[i].material_gap_m, gap);
    const double reserve_strain = material_m / gap - 1.0;
    double rest_over_material = 1.0;
    if (pts[i].tissue.gathered_reserve > 0.0 && pts[i + 1].tissue.gathered_reserve > 0.0 &&
        reserve_strain > kMinReserveStrain) {
      a.pair_toe_N[i] = params.colon_straighten_stiffness_N;
      a.pair_toe_strain[i] = reserve_strain;
      a.pair_reserve_end_m[i] = material_m;
      rest_over_material = gap / material_m;
    }
    a.inverse_material_gap[i] = 1.0 / material_m;
    smallest_pleat_limit =
        std::min(smallest_pleat_limit, a.pair_pleat_limit[i] * rest_over_material);
    const Eigen::Vector3d direction = (pts[i + 1].rest_position_m - pts[i].rest_position_m) / gap;
    const Eigen::Vector3d mean = pts[i].rest_tangent + pts[i + 1].rest_tangent;
    const Eigen::Vector3d mean_tangent =
        mean.norm() > 1e-6 ? Eigen::Vector3d(mean.normalized()) : direction;
    for (int c = 0; c < 3; ++c) {
      a.pair_rest_direction[c][i] = direction[c];
      a.pair_rest_mean_tangent[c][i] = mean_tangent[c];
    }
  }
  for (int i = 1; i + 1 < N; ++i) {
    a.natural_span_m[i] = sc->colon_pair_gap_m[i] + sc->colon_pair_gap_m[i - 1];
  }
  sc->tracking_arc_ratio = params.tracking_arc_ratio > 0.0
                               ? std::max(params.tracking_arc_ratio, 1.2 / smallest_pleat_limit)
                               : 0.0;
}

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

namespace {

// The back substitution of one point, x_i = y_i - G_i x_(i+1): Eigen summed
// the product's first two rows from the left and its third from the right.
// x_(i+1) comes and x_i goes in registers: the substitution is a chain, and
// a trip through memory would add to every link (a vector read of three
// scalar stores is not even forwarded, and waits for them).
[[gnu::always_inline]] inline Eigen::Vector3d SubstituteBack(int i, const Eigen::Vector3d& next,
                                                             ColonSystem* system) {
  double* x = system->solution.data() + 4 * i;
  const double* G = system->gain.data() + 12 * i;
  const double z0 = next[0], z1 = next[1], z2 = next[2];
  const double x0 = x[0] - ((G[0] * z0 + G[1] * z1) + G[2] * z2);
  const double x1 = x[1] - ((G[4] * z0 + G[5] * z1) + G[6] * z2);
  const double x2 = x[2] - (G[8] * z0 + (G[9] * z1 + G[10] * z2));
  x[0] = x0;
  x[1] = x1;
  x[2] = x2;
  return {x0, x1, x2};
}

// The inverse of a symmetric 3x3 matrix (its upper triangle m, the inverse's
// likewise): its adjugate over its determinant, one division. Inlined into
// both builds of the sweep below.
struct SymmetricInverse {
  double i00, i01, i02, i11, i12, i22;
};
[[gnu::always_inline]] inline SymmetricInverse InvertSymmetric(double m00, double m01, double m02,
                                                               double m11, double m12, double m22) {
  const double c00 = m11 * m22 - m12 * m12, c01 = m02 * m12 - m01 * m22,
               c02 = m01 * m12 - m02 * m11, c11 = m00 * m22 - m02 * m02,
               c12 = m01 * m02 - m00 * m12, c22 = m00 * m11 - m01 * m01;
  const double inv_det = 1.0 / (m00 * c00 + m01 * c01 + m02 * c02);
  return {c00 * inv_det, c01 * inv_det, c02 * inv_det, c11 * inv_det, c12 * inv_det, c22 * inv_det};
}

}  // namespace

// Block Thomas over points 1..last (point 0 and the points past `last`
// held): G_i = M_i^-1 U_i, y_i = M_i^-1 (r_i - U_(i-1)^T y_(i-1)) with
// M_i = D_i - U_(i-1)^T G_(i-1) (this forward sweep, y_i into solution);
// then x_i = y_i - G_i x_(i+1) (SubstituteBack, from the last point down).
// M_i is symmetric (D_i is, and U^T M^-1 U is for any U), so only its upper
// triangle is formed and it is inverted by its adjugate: the generic 3x3
// products were most of the step (docs/model.md, "Speed"). The sums are in
// the order Eigen gave them when the blocks were Eigen matrices (see
// Lanes), so the solution is bit for bit the same.
//
// Two builds of the sweep, chosen when the program loads: with AVX2 a row
// of G, M or x is one vector (three lanes used), which takes about a fifth
// off the sweep; on the baseline x86-64 the same rows in two halves were
// twice as slow as scalars, so that build does one entry at a time. Both do
// every entry's operations in the same order: the same bits. (Outside the
// anonymous namespace: Clang counts only the default version's callers and
// would call the other unused.)
#if defined(__x86_64__) && !defined(VES_MODEL_BASELINE_ONLY)
#define VES_BASELINE_BUILD [[gnu::target("default")]]
#else
#define VES_BASELINE_BUILD
#endif
VES_BASELINE_BUILD void EliminateForward(int last, ColonSystem* system) {
  ColonSystem& sys = *system;
  const auto& U = sys.upper;
  double* const G = sys.gain.data();
  double* const x = sys.solution.data();
  for (int i = 1; i <= last; ++i) {
    double m00 = sys.diag[0][i], m01 = sys.diag[1][i], m02 = sys.diag[2][i], m11 = sys.diag[3][i],
           m12 = sys.diag[4][i], m22 = sys.diag[5][i];
    double y0 = sys.rhs[0][i], y1 = sys.rhs[1][i], y2 = sys.rhs[2][i];
    if (i > 1) {
      // M -= U^T G and y -= U^T y_(i-1), column by column of U (entry (r, c) at 3 r + c).
      const int j = i - 1;
      const double* g = G + 12 * j;
      const double u00 = U[0][j], u01 = U[1][j], u02 = U[2][j], u10 = U[3][j], u11 = U[4][j],
                   u12 = U[5][j], u20 = U[6][j], u21 = U[7][j], u22 = U[8][j];
      m00 -= (u00 * g[0] + u10 * g[4]) + u20 * g[8];
      m01 -= (u00 * g[1] + u10 * g[5]) + u20 * g[9];
      m02 -= (u00 * g[2] + u10 * g[6]) + u20 * g[10];
      m11 -= (u01 * g[1] + u11 * g[5]) + u21 * g[9];
      m12 -= (u01 * g[2] + u11 * g[6]) + u21 * g[10];
      m22 -= (u02 * g[2] + u12 * g[6]) + u22 * g[10];
      const double r0 = x[4 * j], r1 = x[4 * j + 1], r2 = x[4 * j + 2];
      y0 -= (u00 * r0 + u10 * r1) + u20 * r2;
      y1 -= (u01 * r0 + u11 * r1) + u21 * r2;
      y2 -= (u02 * r0 + u12 * r1) + u22 * r2;
    }
    const auto [i00, i01, i02, i11, i12, i22] = InvertSymmetric(m00, m01, m02, m11, m12, m22);
    double* g = G + 12 * i;
    for (int c = 0; c < 3; ++c) {
      if (i < last) {
        const double v0 = U[c][i], v1 = U[3 + c][i], v2 = U[6 + c][i];
        g[c] = i00 * v0 + i01 * v1 + i02 * v2;
        g[4 + c] = i01 * v0 + i11 * v1 + i12 * v2;
        g[8 + c] = i02 * v0 + i12 * v1 + i22 * v2;
      } else {
        g[c] = g[4 + c] = g[8 + c] = 0.0;
      }
    }
    x[4 * i] = i00 * y0 + i01 * y1 + i02 * y2;
    x[4 * i + 1] = i01 * y0 + i11 * y1 + i12 * y2;
    x[4 * i + 2] = i02 * y0 + i12 * y1 + i22 * y2;
  }
}

#if defined(__x86_64__) && !defined(VES_MODEL_BASELINE_ONLY)
// The same sweep a row at a time: lane c of a row holds its column c.
[[gnu::target("avx2")]] void EliminateForward(int last, ColonSystem* system) {
  ColonSystem& sys = *system;
  const auto& D = sys.diag;
  const auto& U = sys.upper;
  const auto& R = sys.rhs;
  double* const G = sys.gain.data();
  double* const X = sys.solution.data();
  // G_(i-1)'s rows, U_(i-1)'s rows and y_(i-1), carried to the next point.
  Lanes g0{}, g1{}, g2{}, u0{}, u1{}, u2{}, x{};
  for (int i = 1; i <= last; ++i) {
    Lanes m0 = {D[0][i], D[1][i], D[2][i], 0.0};
    Lanes m1 = {0.0, D[3][i], D[4][i], 0.0};  // lanes 1 and 2 used
    Lanes m2 = {0.0, 0.0, D[5][i], 0.0};      // lane 2 used
    Lanes y = {R[0][i], R[1][i], R[2][i], 0.0};
    if (i > 1) {
      // Row r of M: m(r, c) -= (u_0r g_0c + u_1r g_1c) + u_2r g_2c; y_r likewise.
      const int j = i - 1;
      m0 -= (U[0][j] * g0 + U[3][j] * g1) + U[6][j] * g2;
      m1 -= (U[1][j] * g0 + U[4][j] * g1) + U[7][j] * g2;
      m2 -= (U[2][j] * g0 + U[5][j] * g1) + U[8][j] * g2;
      y -= (u0 * x[0] + u1 * x[1]) + u2 * x[2];
    }
    const double m00 = m0[0], m01 = m0[1], m02 = m0[2], m11 = m1[1], m12 = m1[2], m22 = m2[2];
    const auto [i00, i01, i02, i11, i12, i22] = InvertSymmetric(m00, m01, m02, m11, m12, m22);
    if (i < last) {
      u0 = Lanes{U[0][i], U[1][i], U[2][i], 0.0};
      u1 = Lanes{U[3][i], U[4][i], U[5][i], 0.0};
      u2 = Lanes{U[6][i], U[7][i], U[8][i], 0.0};
      g0 = (i00 * u0 + i01 * u1) + i02 * u2;
      g1 = (i01 * u0 + i11 * u1) + i12 * u2;
      g2 = (i02 * u0 + i12 * u1) + i22 * u2;
    } else {
      g0 = g1 = g2 = Lanes{};
    }
    double* g = G + 12 * i;
    VES_STORE_AT(g, g0);
    VES_STORE_AT(g + 4, g1);
    VES_STORE_AT(g + 8, g2);
    // x_r = (i_r0 y0 + i_r1 y1) + i_r2 y2 (the inverse is symmetric).
    x = (Lanes{i00, i01, i02, 0.0} * y[0] + Lanes{i01, i11, i12, 0.0} * y[1]) +
        Lanes{i02, i12, i22, 0.0} * y[2];
    VES_STORE_AT(X + 4 * i, x);
  }
}
#endif

void SolveBlockTridiagonal(int last, ColonSystem* system) {
  EliminateForward(last, system);
  Eigen::Vector3d x = system->Solution(last);
  for (int i = last - 1; i >= 1; --i) x = SubstituteBack(i, x, system);
}

// flatten: at -O2 GCC left Eigen's small products out of line, and their calls
// were a large part of the solve (docs/model.md, "Speed").
[[gnu::flatten]] void SolveColon(const ModelParams& params, const StepInput& input, ModelState* s,
                                 Scratch* sc) {
  const auto& pts = params.colon.points;
  const int N = static_cast<int>(pts.size());
  const double dt = params.dt_s;
  ColonSystem& sys = sc->colon_system;
  const int last = LastActivePoint(input, *s, N);
  const int end = std::min(last + 1, N - 1);  // first point past the solved ones (or the last)
  const Eigen::Matrix3d I = Eigen::Matrix3d::Identity();

  CopyColonState(*s, end, &sc->colon_arrays);
  // Each point's own terms: damping, the paper's suspension in its rest plane,
  // the mesentery tether and the walls.
  lanes::AddOwnTerms(params, input, *s, end, sc);
  // Neighbour pairs (i, i+1): the axial link and the kink tension.
  lanes::CalcPairTerms(params, end, sc);
  lanes::AddPairTerms(end, sc);
  // Contacts: the scope (at its new shape) presses the wall outward along n;
  // the wall's friction reaction is the opposite of the scope's friction, in
  // every direction (along the scope it drags the colon: pleating).
  const int samples = static_cast<int>(s->samples.size());
  for (int i = s->first_inside_sample; i < samples; ++i) {
    const SampleContact& c = s->contact[i];
    if (!c.touching) continue;
    const int k = c.segment;
    // The penetration at the scope's new shape, to first order in the
    // sample's move during the scope solve (micrometres per step): it changes
    // by n . dp; the normal and the position along the segment are kept.
    const Eigen::Vector3d& normal = sc->sample_normal_W[i];
    const double penetration_m =
        c.penetration_m + normal.dot(s->p_WSample[i] - sc->sample_delta_m[i]);
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
  // Ring contacts: the scope piece pulls the ring's centre toward it (its
  // penetration taken to first order in the piece's move, like the samples').
  for (int j = 0; j < sc->ring_contact_count; ++j) {
    const RingContact& rc = sc->ring_contacts[j];
    const int m = rc.point;
    if (m < 1 || m > last) continue;
    const Eigen::Vector3d moved =
        (1.0 - rc.piece_t) * (s->p_WSample[rc.sample] - sc->sample_delta_m[rc.sample]) +
        rc.piece_t * (s->p_WSample[rc.sample + 1] - sc->sample_delta_m[rc.sample + 1]);
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
  // The elimination, then the back substitution with each point moved as
  // soon as its increment is known: the substitution is a chain of
  // dependent operations, and the moves fill the time it leaves idle.
  EliminateForward(last, &sys);
  const double inv_dt = 1.0 / dt;
  ColonSolverArrays& arrays = sc->colon_arrays;
  Eigen::Vector3d dx = sys.Solution(last);
  for (int i = last; i >= 1; --i) {
    if (i < last) dx = SubstituteBack(i, dx, &sys);
    s->colon_displacement_m[i] += dx;
    s->colon_velocity_m_per_s[i] = dx * inv_dt;
    s->p_WColon[i] = arrays.rest_position_m[i] + s->colon_displacement_m[i];
    // The suspension's reference settles toward where the point is.
    const double relax = sc->colon_relax_factor[i];
    if (relax > 0.0) s->colon_reference_m[i] += relax * (s->p_WColon[i] - s->colon_reference_m[i]);
    for (int c = 0; c < 3; ++c) arrays.position_m[c][i] = s->p_WColon[i][c];
  }
  // UpdateColonDerived(params, 1, last, s), four points at a time (and
  // UpdateColonTangents(0, last + 1, s) at the end).
  const int last_gap = std::min(last, N - 2);
  const int tangents_to = std::min(last + 1, N - 1);
  const int inner_tangents_to = std::min(tangents_to, N - 2);
  lanes::CalcSolvedDistances(params, last, last_gap, sc);
  std::copy(arrays.tether_distance_m.begin() + 1, arrays.tether_distance_m.begin() + last + 1,
            s->colon_tether_distance_m.begin() + 1);
  std::copy(arrays.gap_m.begin() + 1, arrays.gap_m.begin() + last_gap + 2, s->colon_gap_m.begin());
  // Folds set where a gap is held shortened, and release slowly elsewhere.
  if (params.colon_pleat_set_s > 0.0) {
    const double set = dt / (params.colon_pleat_set_s + dt);
    const double release = dt / (params.colon_pleat_release_s + dt);
    for (int i = 0; i < std::min(last + 1, N - 1); ++i) {
      const double g = s->colon_gap_m[i];
      double& rest_m = s->colon_pair_rest_gap_m[i];
      const double natural_m = sc->colon_pair_gap_m[i];
      if (g < rest_m) {
        const double floor_m = sc->colon_arrays.pair_pleat_limit[i] * natural_m;
        rest_m += set * (std::max(g, floor_m) - rest_m);
      } else if (rest_m < natural_m) {
        rest_m += release * (natural_m - rest_m);
      }
    }
  }
  // Where folds have set, the lumen gathers onto the scope (off by default;
  // ModelParams::lumen_gather_pleat). It follows the set folds, which change
  // over colon_pleat_set_s, so the wall closes in gradually.
  if (params.lumen_gather_pleat > 0.0) {
    const double hug_m = 0.5 * params.scope.outer_diameter_m + params.lumen_gather_clearance_m;
    const double g = params.lumen_gather_pleat;
    for (int i = 0; i <= std::min(last + 1, N - 1); ++i) {
      const int a = std::max(i - 1, 0), b = std::min(i, N - 2);
      const double set_ratio = (s->colon_pair_rest_gap_m[a] + s->colon_pair_rest_gap_m[b]) /
                               (sc->colon_pair_gap_m[a] + sc->colon_pair_gap_m[b]);
      const double open = std::clamp((set_ratio - g) / (1.0 - g), 0.0, 1.0);
      const double R = pts[i].radius_m;
      s->colon_lumen_radius_m[i] = R > hug_m ? hug_m + open * (R - hug_m) : R;
    }
  }
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
