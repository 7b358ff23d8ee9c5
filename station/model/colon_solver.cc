// Linearly implicit step of the colon points (paper §3.3, Fig. 8). Point i
// moves only in its plane P_i (2 coordinates d_i in (plane_u, plane_v)):
//   D_c h_i d_i' = -K_c h_i d_i + T/h (neighbour offsets) + contact forces,
// with the suspension, the neighbour coupling (a string under tension T) and
// the contact springs all taken at the end of the step. That is one
// symmetric, diagonally dominant block-tridiagonal system (2x2 blocks), solved
// in O(N) by block Thomas elimination. Point 0 (the anus) is fixed.
#include <algorithm>

#include "station/model/internal.h"

namespace ves::model::internal {
namespace {

Eigen::Matrix<double, 3, 2> PlaneBasis(const ColonPoint& p) {
  Eigen::Matrix<double, 3, 2> B;
  B.col(0) = p.plane_u;
  B.col(1) = p.plane_v;
  return B;
}

}  // namespace

void SolveColon(const ModelParams& params, ModelState* s, Scratch* sc) {
  const auto& pts = params.colon.points;
  const int N = static_cast<int>(pts.size());
  const double dt = params.dt_s;
  auto& diag = sc->colon_diag;
  auto& upper = sc->colon_upper;
  auto& rhs = sc->colon_rhs;
  for (int i = 0; i < N; ++i) {
    const TissueParams& t = pts[i].tissue;
    const double h = pts[i].length_m;
    const double K = t.suspension_stiffness_N_per_m2 * h;
    const double D = t.suspension_damping_N_s_per_m2 * h;
    diag[i] = Eigen::Matrix2d::Identity() * (D + dt * K);
    rhs[i] = -dt * K * s->colon_offset_m[i];  // K_c ||d_ri|| pulls the point home
    upper[i].setZero();
  }
  // Neighbour coupling: force T/h (D_j - D_i) with D the 3-D offsets.
  for (int i = 0; i + 1 < N; ++i) {
    const double T = 0.5 * (pts[i].tissue.neighbor_tension_N + pts[i + 1].tissue.neighbor_tension_N);
    const double gap_m = (pts[i + 1].rest_position_m - pts[i].rest_position_m).norm();
    const double k = T / gap_m;
    const Eigen::Matrix<double, 3, 2> Bi = PlaneBasis(pts[i]);
    const Eigen::Matrix<double, 3, 2> Bj = PlaneBasis(pts[i + 1]);
    const Eigen::Vector3d Di = Bi * s->colon_offset_m[i];
    const Eigen::Vector3d Dj = Bj * s->colon_offset_m[i + 1];
    rhs[i] += dt * k * Bi.transpose() * (Dj - Di);
    rhs[i + 1] += dt * k * Bj.transpose() * (Di - Dj);
    diag[i].diagonal().array() += dt * k;
    diag[i + 1].diagonal().array() += dt * k;
    upper[i].noalias() -= dt * k * Bi.transpose() * Bj;
  }
  // Contacts: the scope (at its new shape) presses the wall outward along n;
  // the wall's friction reaction is the opposite of the scope's friction.
  const int samples = static_cast<int>(s->samples.size());
  for (int i = 0; i < samples; ++i) {
    const SampleContact& c = s->contact[i];
    if (!c.inside || !c.touching) continue;
    const int k = c.segment;
    const SegmentHit hit = CalcSegmentHit(params, *s, k, s->p_WSample[i]);
    const TissueParams& tissue = pts[hit.t < 0.5 ? k : k + 1].tissue;
    WallResponse r = CalcWallResponse(tissue, params.wall_hardening_ratio, hit.penetration_m);
    if (!(hit.penetration_m > 0.0)) {
      // The scope has just moved off this wall: keep the contact's linear
      // spring for the rest of the step, so the point follows the scope back
      // instead of springing into it (an on/off cycle between the two solves).
      r.slope_N_per_m = sc->sample_normal_slope_N_per_m[i];
      r.force_N = r.slope_N_per_m * hit.penetration_m;
    }
    const Eigen::Vector3d f_wall = r.force_N * hit.normal - sc->sample_friction_W_N[i];
    const double w[2] = {1.0 - hit.t, hit.t};
    Eigen::Matrix<double, 3, 2> B[2];
    for (int j = 0; j < 2; ++j) {
      B[j] = PlaneBasis(pts[k + j]);
      rhs[k + j] += dt * w[j] * (B[j].transpose() * f_wall);
    }
    // The wall force falls as the points follow the scope (d f / d r = -slope
    // n n^T), the wall damping D_d (eq. 9) and the friction stick spring act on
    // the relative motion from this side too; all implicit, otherwise a light
    // colon point jumps by the whole force in one step and chatters.
    const Eigen::Matrix3d nn = hit.normal * hit.normal.transpose();
    const Eigen::Matrix3d K3 =
        (dt * r.slope_N_per_m + tissue.wall_damping_N_s_per_m) * nn +
        dt * params.friction_stiffness_N_per_m * (Eigen::Matrix3d::Identity() - nn);
    diag[k] += w[0] * w[0] * B[0].transpose() * K3 * B[0];
    diag[k + 1] += w[1] * w[1] * B[1].transpose() * K3 * B[1];
    upper[k] += w[0] * w[1] * B[0].transpose() * K3 * B[1];
  }
  // Block Thomas elimination with point 0 held fixed (the anus).
  auto& minv = sc->colon_work;
  rhs[0].setZero();
  minv[0].setZero();
  for (int i = 1; i < N; ++i) {
    Eigen::Matrix2d M = diag[i];
    Eigen::Vector2d y = rhs[i];
    if (i > 1) {
      const Eigen::Matrix2d L = upper[i - 1].transpose();  // block (i, i-1)
      const Eigen::Matrix2d LMinv = L * minv[i - 1];
      M.noalias() -= LMinv * upper[i - 1];
      y.noalias() -= LMinv * rhs[i - 1];
    }
    minv[i] = M.inverse();
    rhs[i] = y;
  }
  rhs[N - 1] = minv[N - 1] * rhs[N - 1];
  for (int i = N - 2; i >= 1; --i) {
    rhs[i] = minv[i] * (rhs[i] - upper[i] * rhs[i + 1]);
  }
  // rhs now holds the increments of d_i.
  for (int i = 1; i < N; ++i) {
    s->colon_offset_m[i] += rhs[i];
    s->colon_rate_m_per_s[i] = rhs[i] / dt;
    s->p_WColon[i] = pts[i].rest_position_m + PlaneBasis(pts[i]) * s->colon_offset_m[i];
  }
}

}  // namespace ves::model::internal
