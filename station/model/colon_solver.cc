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
#include <algorithm>
#include <cmath>

#include "station/model/internal.h"

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

int LastActivePoint(const ModelState& s, int N) {
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

// The direction a pair of neighbours is pulled toward: its rest direction
// turned by the smallest rotation that takes the pair's rest mean tangent to
// its current one (the colon turned as a whole exerts no kink force).
Eigen::Vector3d CalcKinkDirection(const Eigen::Vector3d& rest_mean, const Eigen::Vector3d& mean_sum,
                                  const Eigen::Vector3d& rest_direction,
                                  const Eigen::Vector3d& fallback) {
  const double length = mean_sum.norm();
  if (length < 1e-6) return fallback;
  // Rodrigues for the rotation taking rest_mean onto mean = mean_sum / length:
  // v + c x v + c x (c x v) / (1 + cos) with c = rest_mean x mean, cos =
  // rest_mean . mean (a rotation: the unit rest direction stays unit). Taken
  // with the unnormalised sum, c' = length c and cos' = length cos, it needs
  // one division: 1 / (length (length + cos')).
  const Eigen::Vector3d c = rest_mean.cross(mean_sum);
  const double cos_sum = rest_mean.dot(mean_sum);
  if (cos_sum < -0.99 * length) return fallback;  // turned about half a turn: no smallest rotation
  const double inv = 1.0 / (length * (length + cos_sum));
  const Eigen::Vector3d cv = c.cross(rest_direction);
  return rest_direction + ((length + cos_sum) * inv) * cv + inv * c.cross(cv);
}

}  // namespace

PairAxial CalcPairAxial(const ModelParams& params, double toe_N, double pleat_limit, double strain) {
  const double soft = params.colon_pleat_stiffness_N;
  if (strain >= 0.0) {
    // Tension, J-shaped: the slope rises from `soft` to the toe's over the
    // onset strain, stays there through the toe, then becomes EA (the wall's
    // linear modulus).
    const double toe = toe_N;
    const double e_b = std::min(kTensionOnsetStrain, params.colon_toe_strain);
    const double e_t = params.colon_toe_strain;
    if (strain <= e_b) {
      return {soft * strain + (toe - soft) * strain * strain / (2.0 * e_b),
              soft + (toe - soft) * strain / e_b};
    }
    const double at_onset_N = soft * e_b + (toe - soft) * e_b / 2.0;
    if (strain <= e_t) return {at_onset_N + toe * (strain - e_b), toe};
    return {at_onset_N + toe * (e_t - e_b) + params.colon_tension_stiffness_N * (strain - e_t),
            params.colon_tension_stiffness_N};
  }
  // Shortening: the wall folds onto the scope ("pleats", the accordion of
  // real colonoscopy) until the gap is pleat_limit of its rest length; then
  // the folds are packed.
  const double limit = pleat_limit - 1.0;  // <= 0
  if (strain >= limit) return {soft * strain, soft};
  return {soft * limit + params.colon_packed_stiffness_N * (strain - limit),
          params.colon_packed_stiffness_N};
}

void PrepareColonSystem(const ModelParams& params, Scratch* sc) {
  const auto& pts = params.colon.points;
  const int N = static_cast<int>(pts.size());
  sc->colon_suspension_N_per_m.assign(N, 0.0);
  sc->colon_tether_N_per_m.assign(N, 0.0);
  sc->colon_own_diag.assign(N, Eigen::Matrix3d::Zero());
  sc->colon_relax_factor.assign(N, 0.0);
  sc->colon_pair_gap_m.assign(N, 1.0);
  sc->colon_pair_kink_N_per_m.assign(N, 0.0);
  sc->colon_pair_pleat_limit.assign(N, 1.0);
  sc->colon_pair_toe_N.assign(N, params.colon_tension_stiffness_N);
  sc->colon_pair_rest_direction.assign(N, Eigen::Vector3d::UnitZ());
  sc->colon_pair_rest_mean_tangent.assign(N, Eigen::Vector3d::UnitZ());
  double smallest_pleat_limit = 1.0;
  const Eigen::Matrix3d I = Eigen::Matrix3d::Identity();
  for (int i = 0; i < N; ++i) {
    const TissueParams& t = pts[i].tissue;
    const double h = pts[i].length_m;
    sc->colon_suspension_N_per_m[i] = t.suspension_stiffness_N_per_m2 * h;
    sc->colon_tether_N_per_m[i] = t.mesentery_stiffness_N_per_m2 * h;
    const Eigen::Matrix3d P = I - pts[i].rest_tangent * pts[i].rest_tangent.transpose();
    sc->colon_own_diag[i] = (t.suspension_damping_N_s_per_m2 * h) * I +
                            (params.dt_s * sc->colon_suspension_N_per_m[i]) * P;
    if (t.suspension_relaxation_s > 0.0) {
      sc->colon_relax_factor[i] = params.dt_s / (t.suspension_relaxation_s + params.dt_s);
    }
    smallest_pleat_limit = std::min(smallest_pleat_limit, t.pleat_limit);
  }
  const auto has_toe = [&](Region r) {
    return ((params.colon_toe_regions >> static_cast<unsigned>(r)) & 1u) != 0;
  };
  for (int i = 0; i + 1 < N; ++i) {
    const double gap = (pts[i + 1].rest_position_m - pts[i].rest_position_m).norm();
    const double T =
        0.5 * (pts[i].tissue.neighbor_tension_N + pts[i + 1].tissue.neighbor_tension_N);
    sc->colon_pair_gap_m[i] = gap;
    sc->colon_pair_kink_N_per_m[i] = T / gap;
    sc->colon_pair_pleat_limit[i] = std::min(pts[i].tissue.pleat_limit, pts[i + 1].tissue.pleat_limit);
    if (has_toe(pts[i].region) && has_toe(pts[i + 1].region)) {
      sc->colon_pair_toe_N[i] = params.colon_toe_stiffness_N;
    }
    sc->colon_pair_rest_direction[i] = (pts[i + 1].rest_position_m - pts[i].rest_position_m) / gap;
    const Eigen::Vector3d mean = pts[i].rest_tangent + pts[i + 1].rest_tangent;
    sc->colon_pair_rest_mean_tangent[i] =
        mean.norm() > 1e-6 ? Eigen::Vector3d(mean.normalized()) : sc->colon_pair_rest_direction[i];
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

// Block Thomas over points 1..last (point 0 and the points past `last`
// held): G_i = M_i^-1 U_i, y_i = M_i^-1 (r_i - U_(i-1)^T y_(i-1)) with
// M_i = D_i - U_(i-1)^T G_(i-1); then x_i = y_i - G_i x_(i+1). M_i is
// symmetric (D_i is, and U^T M^-1 U is for any U), so only its upper
// triangle is formed and it is inverted by its adjugate, in scalars: the
// generic 3x3 products were most of the step (docs/model.md, "Speed").
[[gnu::flatten]] void SolveBlockTridiagonal(const std::vector<Eigen::Matrix3d>& diag,
                                            const std::vector<Eigen::Matrix3d>& upper, int last,
                                            std::vector<Eigen::Vector3d>* rhs_io,
                                            std::vector<Eigen::Matrix3d>* gain_io) {
  auto& rhs = *rhs_io;
  auto& gain = *gain_io;
  for (int i = 1; i <= last; ++i) {
    const Eigen::Matrix3d& D = diag[i];
    double m00 = D(0, 0), m01 = D(0, 1), m02 = D(0, 2), m11 = D(1, 1), m12 = D(1, 2), m22 = D(2, 2);
    Eigen::Vector3d y = rhs[i];
    if (i > 1) {
      const Eigen::Matrix3d& U = upper[i - 1];
      const Eigen::Matrix3d& G = gain[i - 1];
      const Eigen::Vector3d u0 = U.col(0), u1 = U.col(1), u2 = U.col(2);
      m00 -= u0.dot(G.col(0));
      m01 -= u0.dot(G.col(1));
      m02 -= u0.dot(G.col(2));
      m11 -= u1.dot(G.col(1));
      m12 -= u1.dot(G.col(2));
      m22 -= u2.dot(G.col(2));
      const Eigen::Vector3d& r = rhs[i - 1];
      y -= Eigen::Vector3d(u0.dot(r), u1.dot(r), u2.dot(r));
    }
    // The adjugate of the symmetric M over its determinant.
    const double c00 = m11 * m22 - m12 * m12, c01 = m02 * m12 - m01 * m22,
                 c02 = m01 * m12 - m02 * m11, c11 = m00 * m22 - m02 * m02,
                 c12 = m01 * m02 - m00 * m12, c22 = m00 * m11 - m01 * m01;
    const double inv_det = 1.0 / (m00 * c00 + m01 * c01 + m02 * c02);
    const double i00 = c00 * inv_det, i01 = c01 * inv_det, i02 = c02 * inv_det,
                 i11 = c11 * inv_det, i12 = c12 * inv_det, i22 = c22 * inv_det;
    auto apply_inverse = [&](const Eigen::Vector3d& v) {
      return Eigen::Vector3d(i00 * v.x() + i01 * v.y() + i02 * v.z(),
                             i01 * v.x() + i11 * v.y() + i12 * v.z(),
                             i02 * v.x() + i12 * v.y() + i22 * v.z());
    };
    if (i < last) {
      const Eigen::Matrix3d& U = upper[i];
      gain[i].col(0) = apply_inverse(U.col(0));
      gain[i].col(1) = apply_inverse(U.col(1));
      gain[i].col(2) = apply_inverse(U.col(2));
    } else {
      gain[i].setZero();
    }
    rhs[i] = apply_inverse(y);
  }
  for (int i = last - 1; i >= 1; --i) rhs[i] -= gain[i] * rhs[i + 1];
}

// flatten: at -O2 GCC left Eigen's small products out of line, and their calls
// were a large part of the solve (docs/model.md, "Speed").
[[gnu::flatten]] void SolveColon(const ModelParams& params, const StepInput& input, ModelState* s,
                                 Scratch* sc) {
  const auto& pts = params.colon.points;
  const int N = static_cast<int>(pts.size());
  const double dt = params.dt_s;
  auto& diag = sc->colon_diag;
  auto& upper = sc->colon_upper;
  auto& rhs = sc->colon_rhs;
  const auto& x = s->p_WColon;
  const int last = LastActivePoint(*s, N);
  const int end = std::min(last + 1, N - 1);  // first point past the solved ones (or the last)
  const Eigen::Matrix3d I = Eigen::Matrix3d::Identity();
  const double shear_ratio = params.colon.mesentery_shear_ratio;

  // Each point's own terms: damping, the paper's suspension in its rest plane
  // and the mesentery tether.
  for (int i = 0; i <= end; ++i) {
    const ColonPoint& p = pts[i];
    const double K_c = sc->colon_suspension_N_per_m[i];
    diag[i] = sc->colon_own_diag[i];
    // paper §3.3.2: K_c ||d_ri|| pulls the point home within its plane P_i
    // (home: its reference, which may have settled since rest).
    const Eigen::Vector3d d = x[i] - s->colon_reference_m[i];
    rhs[i] = -(dt * K_c) * (d - p.rest_tangent.dot(d) * p.rest_tangent);
    upper[i].setZero();
    // Mesentery: its reach is measured in the tether's metric, in which a
    // move along the root counts mesentery_shear_ratio times: rho^2 = r^T G r
    // with G = I + (s^2 - 1) c c^T. Taut (rho > L), it pulls with
    // k (rho - L) G r / rho; its stiffness is k [g g^T + (1 - L/rho)(G - g g^T)]
    // with g = G r / rho (positive semidefinite: G is).
    const Eigen::Vector3d r = x[i] - p.tether_anchor_m;
    const double rho = s->colon_tether_distance_m[i];
    double reach_m = p.tether_length_m;
    if (params.mesentery_reach_gathers && p.tissue.mobile && i > 0 && i < N - 1) {
      const double now = s->colon_gap_m[i] + s->colon_gap_m[i - 1];
      const double natural = sc->colon_pair_gap_m[i] + sc->colon_pair_gap_m[i - 1];
      const double ratio = natural > 1e-12 ? std::min(1.0, now / natural) : 1.0;
      reach_m = std::max(p.tissue.mesentery_length_m, p.tether_length_m * ratio);
    }
    if (rho > reach_m && rho > 1e-12) {
      const double k = sc->colon_tether_N_per_m[i];
      const Eigen::Vector3d& c = p.tether_root_direction;
      const Eigen::Matrix3d G = I + (shear_ratio * shear_ratio - 1.0) * c * c.transpose();
      const Eigen::Vector3d g = G * r / rho;
      const double across = 1.0 - reach_m / rho;
      rhs[i] -= (dt * k * (rho - reach_m)) * g;
      diag[i] += (dt * k) * (g * g.transpose() + across * (G - g * g.transpose()));
    }
    // The colon hangs on one side of its root: swung through it by more
    // than mesentery_crossing_m, it meets the body wall behind the root.
    const double crossed_m = -(r.dot(p.tether_side) + params.colon.mesentery_crossing_m);
    if (crossed_m > 0.0 && p.tether_side.squaredNorm() > 0.5) {
      const double k = params.colon.root_wall_stiffness_N_per_m2 * p.length_m;
      rhs[i] += (dt * k * crossed_m) * p.tether_side;
      diag[i] += (dt * k) * p.tether_side * p.tether_side.transpose();
    }
    // The assistant's hand: a pressed mobile point is held within the slack
    // of its root (isotropic; the same implicit form as the tether).
    const double pressure = input.abdominal_pressure[static_cast<int>(p.region)];
    if (pressure > 0.0 && p.tissue.mobile) {
      const double d = r.norm();
      const double slack = params.abdominal_pressure_slack_m;
      if (d > slack) {
        const double k = pressure * params.abdominal_pressure_stiffness_N_per_m2 * p.length_m;
        const Eigen::Vector3d g = r / d;
        rhs[i] -= (dt * k * (d - slack)) * g;
        diag[i] += (dt * k) * (g * g.transpose() + (1.0 - slack / d) * (I - g * g.transpose()));
      }
    }
    // The abdominal cavity (ColonSpec::abdomen_*): a wall on each face.
    for (int axis = 0; axis < 3; ++axis) {
      const double below_m = params.colon.abdomen_min_m[axis] - x[i][axis];
      const double above_m = x[i][axis] - params.colon.abdomen_max_m[axis];
      const double out_m = below_m > 0.0 ? below_m : (above_m > 0.0 ? -above_m : 0.0);
      if (out_m == 0.0) continue;
      const double k = params.colon.root_wall_stiffness_N_per_m2 * p.length_m;
      rhs[i][axis] += dt * k * out_m;
      diag[i](axis, axis) += dt * k;
    }
  }
  // Neighbour pairs (i, i+1): the axial link and the kink tension.
  for (int i = 0; i < end; ++i) {
    const Eigen::Vector3d seg = x[i + 1] - x[i];
    const double g = s->colon_gap_m[i];
    const double inv_g = g > 1e-12 ? 1.0 / g : 0.0;
    // Strain against the gap's rest length (shorter where folds have set);
    // the folds pack at pleat_limit of the natural gap.
    const double inv_g0 = 1.0 / s->colon_pair_rest_gap_m[i];
    const double natural_gap_m = sc->colon_pair_gap_m[i];
    const Eigen::Vector3d u = g > 1e-12 ? Eigen::Vector3d(seg * inv_g) : pts[i].rest_tangent;
    const double pleat_limit = sc->colon_pair_pleat_limit[i] * natural_gap_m * inv_g0;
    const PairAxial a = CalcPairAxial(params, sc->colon_pair_toe_N[i], std::min(pleat_limit, 1.0),
                                      g * inv_g0 - 1.0);
    // Tension also resists the pair turning (a taut string); compression does
    // not push it sideways (dropping that term keeps the matrix definite).
    // Kink tension: the pair is pulled toward the tube's local direction,
    // never along it, so the tube stays smooth and still pleats freely. That
    // direction is the pair's rest direction turned as the mean of its ends'
    // tangents has turned since rest (tangents of the start of the step), so
    // the colon at rest feels no force.
    const Eigen::Vector3d m = CalcKinkDirection(sc->colon_pair_rest_mean_tangent[i],
                                                s->colon_tangent[i] + s->colon_tangent[i + 1],
                                                sc->colon_pair_rest_direction[i], u);
    const double k = sc->colon_pair_kink_N_per_m[i];  // T over the natural gap
    // C = (slope/g0) u u^T + (f/g)(I - u u^T) [taut only] + k (I - m m^T).
    const double taut = a.force_N > 0.0 ? a.force_N * inv_g : 0.0;
    const Eigen::Matrix3d dtC = (dt * (taut + k)) * I +
                                (dt * (a.slope_N * inv_g0 - taut)) * (u * u.transpose()) -
                                (dt * k) * (m * m.transpose());
    const Eigen::Vector3d F = a.force_N * u + k * (seg - m.dot(seg) * m);  // on point i; -F on i+1
    diag[i] += dtC;
    diag[i + 1] += dtC;
    upper[i] = -dtC;
    rhs[i] += dt * F;
    rhs[i + 1] -= dt * F;
  }
  upper[end].setZero();
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
      rhs[k] += (dt * w0) * f_wall;
      diag[k] += (w0 * w0) * K3;
    }
    if (k + 1 <= last) {
      rhs[k + 1] += (dt * w1) * f_wall;
      diag[k + 1] += (w1 * w1) * K3;
      if (k >= 1) upper[k] += (w0 * w1) * K3;
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
    rhs[m] += (dt * force_N) * rc.normal_W;
    diag[m] += a * rc.normal_W * rc.normal_W.transpose();
  }
  SolveBlockTridiagonal(diag, upper, last, &rhs, &sc->colon_work);

  const double inv_dt = 1.0 / dt;
  for (int i = 1; i <= last; ++i) {
    s->colon_displacement_m[i] += rhs[i];
    s->colon_velocity_m_per_s[i] = rhs[i] * inv_dt;
    s->p_WColon[i] = pts[i].rest_position_m + s->colon_displacement_m[i];
    // The suspension's reference settles toward where the point is.
    const double relax = sc->colon_relax_factor[i];
    if (relax > 0.0) s->colon_reference_m[i] += relax * (s->p_WColon[i] - s->colon_reference_m[i]);
  }
  UpdateColonDerived(params, 1, last, s);
  // Folds set where a gap is held shortened, and release slowly elsewhere.
  if (params.colon_pleat_set_s > 0.0) {
    const double set = dt / (params.colon_pleat_set_s + dt);
    const double release = dt / (params.colon_pleat_release_s + dt);
    for (int i = 0; i < std::min(last + 1, N - 1); ++i) {
      const double g = s->colon_gap_m[i];
      double& rest_m = s->colon_pair_rest_gap_m[i];
      const double natural_m = sc->colon_pair_gap_m[i];
      if (g < rest_m) {
        const double floor_m = sc->colon_pair_pleat_limit[i] * natural_m;
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
  rhs[0].setZero();
  for (int i = last + 1; i < N; ++i) {
    rhs[i].setZero();
    s->colon_velocity_m_per_s[i].setZero();
  }
  UpdateColonTangents(0, last + 1, s);
}

}  // namespace ves::model::internal
