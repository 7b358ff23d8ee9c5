// Linearly implicit step of the colon points (paper §3.3, Fig. 8). Point i
// moves only in its plane P_i (2 coordinates d_i in (plane_u, plane_v)):
//   D_c h_i d_i' = -K_c h_i d_i + T/h (neighbour offsets) + contact forces,
// with the suspension, the neighbour coupling (a string under tension T) and
// the contact springs all taken at the end of the step. That is one
// symmetric, diagonally dominant block-tridiagonal system (2x2 blocks), solved
// in O(N) by block Thomas elimination. Point 0 (the anus) is fixed.
// With the axial give on (colon_longitudinal_stiffness_N > 0, experimental),
// each point also slides along its rest tangent: a scalar tridiagonal system
// solved after the in-plane one (docs/model.md, "Axial give").
#include <algorithm>
#include <cmath>

#include "station/model/internal.h"

namespace ves::model::internal {
namespace {

Eigen::Matrix<double, 3, 2> PlaneBasis(const ColonPoint& p) {
  Eigen::Matrix<double, 3, 2> B;
  B.col(0) = p.plane_u;
  B.col(1) = p.plane_v;
  return B;
}

// Beyond a few points past the deepest contact and past every point still
// displaced or moving, the colon is at rest and stays there: no force reaches
// it but the coupling to points that are themselves at rest. The solve covers
// points 1..last only (docs/model.md, "Time step"); a point within kRestOffset_m of
// home that no contact touches is held (its suspension would return it by at
// most that much).
constexpr double kRestOffset_m = 1e-7;
constexpr double kOneStep_s = 1e-3;  // a rate that moves a point less than that per ms is rest
constexpr int kActiveMargin = 4;  // points solved past the last disturbed one

int LastActivePoint(const ModelState& s, int N) {
  int last = 0;
  const int samples = static_cast<int>(s.samples.size());
  for (int i = s.first_inside_sample; i < samples; ++i) {
    last = std::max(last, s.contact[i].segment + 1);
  }
  for (int i = N - 1; i > last; --i) {
    if (s.colon_offset_m[i].cwiseAbs().maxCoeff() > kRestOffset_m ||
        s.colon_rate_m_per_s[i].cwiseAbs().maxCoeff() * kOneStep_s > kRestOffset_m ||
        std::abs(s.colon_axial_m[i]) > kRestOffset_m ||
        std::abs(s.colon_axial_rate_m_per_s[i]) * kOneStep_s > kRestOffset_m) {
      last = i;
      break;
    }
  }
  return std::min(N - 1, last + kActiveMargin);
}

// Axial force between neighbours (+ pulls them together) for the strain e of
// their gap and its slope per unit strain: the wall's longitudinal stiffness
// EA when stretched; when shortened the wall folds onto the scope ("pleats",
// the accordion of real colonoscopy) at pleat_ratio * EA until the shortening
// reaches pleat_limit, then the packed folds resist at hardening * EA.
struct PairAxial {
  double force_N;
  double slope_N;
};
PairAxial CalcPairAxial(const ModelParams& params, double strain) {
  const double EA = params.colon_longitudinal_stiffness_N;
  if (strain >= 0.0) return {EA * strain, EA};
  const double soft = params.colon_pleat_stiffness_ratio * EA;
  const double limit = params.colon_pleat_limit;
  if (strain >= -limit) return {soft * strain, soft};
  const double hard = params.colon_pleat_hardening_ratio * EA;
  return {-soft * limit + hard * (strain + limit), hard};
}

// Tridiagonal (Thomas) solve of the axial increments over points 1..last.
void SolveAxial(int last, Scratch* sc) {
  auto& diag = sc->axial_diag;
  const auto& upper = sc->axial_upper;
  auto& rhs = sc->axial_rhs;
  auto& gain = sc->axial_work;
  for (int i = 1; i <= last; ++i) {
    double m = diag[i];
    double y = rhs[i];
    if (i > 1) {
      m -= upper[i - 1] * gain[i - 1];
      y -= upper[i - 1] * rhs[i - 1];
    }
    const double m_inv = 1.0 / m;
    gain[i] = upper[i] * m_inv;
    rhs[i] = y * m_inv;
  }
  for (int i = last - 1; i >= 1; --i) rhs[i] -= gain[i] * rhs[i + 1];
}

}  // namespace

void PrepareColonSystem(const ModelParams& params, Scratch* sc) {
  const auto& pts = params.colon.points;
  const int N = static_cast<int>(pts.size());
  const double dt = params.dt_s;
  sc->colon_pair_k_N_per_m.assign(N, 0.0);
  sc->colon_pair_transfer.assign(N, Eigen::Matrix2d::Zero());
  sc->colon_suspension_N_per_m.assign(N, 0.0);
  sc->colon_base_diag.assign(N, 0.0);
  sc->axial_pair_gap_m.assign(N, 1.0);
  for (int i = 0; i + 1 < N; ++i) {
    sc->axial_pair_gap_m[i] = (pts[i + 1].rest_position_m - pts[i].rest_position_m).norm();
  }
  for (int i = 0; i < N; ++i) {
    const TissueParams& t = pts[i].tissue;
    const double h = pts[i].length_m;
    sc->colon_suspension_N_per_m[i] = t.suspension_stiffness_N_per_m2 * h;
    sc->colon_base_diag[i] +=
        t.suspension_damping_N_s_per_m2 * h + dt * sc->colon_suspension_N_per_m[i];
  }
  sc->colon_stiffness_diag.assign(N, 0.0);
  sc->colon_pair_upper.assign(N, Eigen::Matrix2d::Zero());
  for (int i = 0; i < N; ++i) sc->colon_stiffness_diag[i] = dt * sc->colon_suspension_N_per_m[i];
  for (int i = 0; i + 1 < N; ++i) {
    const double T =
        0.5 * (pts[i].tissue.neighbor_tension_N + pts[i + 1].tissue.neighbor_tension_N);
    const double k = T / (pts[i + 1].rest_position_m - pts[i].rest_position_m).norm();
    sc->colon_pair_k_N_per_m[i] = k;
    sc->colon_pair_transfer[i] = PlaneBasis(pts[i]).transpose() * PlaneBasis(pts[i + 1]);
    sc->colon_pair_upper[i] = -dt * k * sc->colon_pair_transfer[i];
    sc->colon_base_diag[i] += dt * k;
    sc->colon_base_diag[i + 1] += dt * k;
    sc->colon_stiffness_diag[i] += dt * k;
    sc->colon_stiffness_diag[i + 1] += dt * k;
  }
}

void SolveColon(const ModelParams& params, ModelState* s, Scratch* sc) {
  const auto& pts = params.colon.points;
  const int N = static_cast<int>(pts.size());
  const double dt = params.dt_s;
  auto& diag = sc->colon_diag;
  auto& upper = sc->colon_upper;
  auto& rhs = sc->colon_rhs;
  const auto& d = s->colon_offset_m;
  const int last = LastActivePoint(*s, N);
  // Suspension (K_c ||d_ri|| pulls the point home) and the neighbour coupling,
  // a force T/h (D_j - D_i) on the 3-D offsets D = B d; in plane i that is
  // T/h (C_i d_j - d_i) with the constant C_i = B_i^T B_j (orthonormal B).
  // With the constant blocks U_i = -dt T/h C_i, the explicit part of the
  // right-hand side is -dt K d: -S_i d_i - U_(i-1)^T d_(i-1) - U_i d_(i+1).
  const int end = std::min(last + 1, N - 1);  // first point past the solved ones (or the last)
  const auto& U = sc->colon_pair_upper;
  const auto& S = sc->colon_stiffness_diag;
  const auto& base = sc->colon_base_diag;
  for (int i = 0; i <= end; ++i) {
    diag[i] = Eigen::Matrix2d::Identity() * base[i];
    upper[i] = i < end ? U[i] : Eigen::Matrix2d::Zero();
    rhs[i].setZero();  // the contacts' part; the explicit part is added in the elimination
  }
  // The explicit part for point i (1 <= i <= last). It is computed inside the
  // elimination loop, whose chains are latency-bound and leave room for it.
  auto explicit_rhs = [&](int i) {
    const Eigen::Vector2d& dp = d[i - 1];
    const Eigen::Matrix2d& Up = U[i - 1];
    Eigen::Vector2d r(-S[i] * d[i].x() - (Up(0, 0) * dp.x() + Up(1, 0) * dp.y()),
                      -S[i] * d[i].y() - (Up(0, 1) * dp.x() + Up(1, 1) * dp.y()));
    if (i + 1 < N) {  // U[N-1] is zero: the deepest point has no next neighbour
      const Eigen::Vector2d& dn = d[i + 1];
      const Eigen::Matrix2d& Un = U[i];
      r.x() -= Un(0, 0) * dn.x() + Un(0, 1) * dn.y();
      r.y() -= Un(1, 0) * dn.x() + Un(1, 1) * dn.y();
    }
    return r;
  };
  // Axial give (docs/model.md): the same suspension anchors the point along
  // its tangent; neighbours resist a change of their gap (CalcPairAxial).
  // Implicit like the in-plane part; the anus point is fixed.
  const bool axial = params.colon_longitudinal_stiffness_N > 0.0;
  auto& a_diag = sc->axial_diag;
  auto& a_upper = sc->axial_upper;
  auto& a_rhs = sc->axial_rhs;
  if (axial) {
    const auto& a = s->colon_axial_m;
    for (int i = 0; i <= end; ++i) {
      const double h = pts[i].length_m;
      a_diag[i] = pts[i].tissue.suspension_damping_N_s_per_m2 * h +
                  dt * sc->colon_suspension_N_per_m[i];
      a_rhs[i] = -dt * sc->colon_suspension_N_per_m[i] * a[i];
      a_upper[i] = 0.0;
    }
    for (int i = 0; i < end; ++i) {
      const double gap = sc->axial_pair_gap_m[i];
      const PairAxial f = CalcPairAxial(params, (a[i + 1] - a[i]) / gap);
      const double k = f.slope_N / gap;
      a_rhs[i] += dt * f.force_N;
      a_rhs[i + 1] -= dt * f.force_N;
      a_diag[i] += dt * k;
      a_diag[i + 1] += dt * k;
      a_upper[i] = -dt * k;
    }
  }
  // Contacts: the scope (at its new shape) presses the wall outward along n;
  // the wall's friction reaction is the opposite of the scope's friction.
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
    const double w[2] = {1.0 - t, t};
    Eigen::Vector2d v[2];  // the normal in the two planes, B_j^T n
    for (int j = 0; j < 2; ++j) {
      const ColonPoint& q = pts[k + j];
      rhs[k + j] += dt * w[j] * Eigen::Vector2d(q.plane_u.dot(f_wall), q.plane_v.dot(f_wall));
      v[j] = Eigen::Vector2d(q.plane_u.dot(normal), q.plane_v.dot(normal));
    }
    // The wall force falls as the points follow the scope (d f / d r = -slope
    // n n^T), the wall damping D_d (eq. 9) and the friction stick spring act on
    // the relative motion from this side too; all implicit, otherwise a light
    // colon point jumps by the whole force in one step and chatters. With
    // K3 = a n n^T + b (I - n n^T): B_j^T K3 B_l = b B_j^T B_l + (a - b) v_j v_l^T.
    const double a = dt * r.slope_N_per_m + tissue.wall_damping_N_s_per_m;
    const double b = dt * params.friction_stiffness_N_per_m;
    diag[k].noalias() += w[0] * w[0] * (a - b) * v[0] * v[0].transpose();
    diag[k].diagonal().array() += w[0] * w[0] * b;
    diag[k + 1].noalias() += w[1] * w[1] * (a - b) * v[1] * v[1].transpose();
    diag[k + 1].diagonal().array() += w[1] * w[1] * b;
    upper[k].noalias() +=
        w[0] * w[1] * (b * sc->colon_pair_transfer[k] + (a - b) * v[0] * v[1].transpose());
    if (axial) {
      // Along the tangents: friction drags the wall along the scope (the
      // stick spring b), and the normal has an axial part only at the pole.
      const Eigen::Vector3d& t0 = pts[k].rest_tangent;
      const Eigen::Vector3d& t1 = pts[k + 1].rest_tangent;
      const double tn[2] = {t0.dot(normal), t1.dot(normal)};
      a_rhs[k] += dt * w[0] * t0.dot(f_wall);
      a_rhs[k + 1] += dt * w[1] * t1.dot(f_wall);
      a_diag[k] += w[0] * w[0] * (b + (a - b) * tn[0] * tn[0]);
      a_diag[k + 1] += w[1] * w[1] * (b + (a - b) * tn[1] * tn[1]);
      a_upper[k] += w[0] * w[1] * (b * t0.dot(t1) + (a - b) * tn[0] * tn[1]);
    }
  }
  // Block tridiagonal solve over points 1..last, point 0 (the anus) and the
  // points past `last` held where they are. Twisted ("burn at both ends")
  // elimination: the top half from point 1 down, G_i = M_i^-1 U_i and
  // y_i = M_i^-1 (r_i - U_(i-1)^T y_(i-1)) with M_i = D_i - U_(i-1)^T G_(i-1);
  // the bottom half from `last` up, H_i = N_i^-1 U_(i-1)^T and
  // w_i = N_i^-1 (r_i - U_i w_(i+1)) with N_i = D_i - U_i H_(i+1). The two
  // chains are independent, so the CPU overlaps them (each point's 2x2
  // inverse is a long dependency); they meet at p, p+1.
  auto& gain = sc->colon_work;  // G_i for i <= p, H_i for i > p
  const int p = (last + 1) / 2;
  // Written out in scalars: M and N are symmetric (so are D_i and U^T G),
  // and Eigen's generic 2x2 products and inverse cost about twice the
  // instructions of this on the solve's critical path.
  auto eliminate_top = [&](int i) {
    const Eigen::Matrix2d& D = diag[i];
    double m00 = D(0, 0), m01 = D(0, 1), m11 = D(1, 1);
    const Eigen::Vector2d r = rhs[i] + explicit_rhs(i);
    double y0 = r.x(), y1 = r.y();
    if (i > 1) {
      const Eigen::Matrix2d& Up = upper[i - 1];
      const Eigen::Matrix2d& G = gain[i - 1];
      const Eigen::Vector2d& yp = rhs[i - 1];
      m00 -= Up(0, 0) * G(0, 0) + Up(1, 0) * G(1, 0);
      m01 -= Up(0, 0) * G(0, 1) + Up(1, 0) * G(1, 1);
      m11 -= Up(0, 1) * G(0, 1) + Up(1, 1) * G(1, 1);
      y0 -= Up(0, 0) * yp.x() + Up(1, 0) * yp.y();
      y1 -= Up(0, 1) * yp.x() + Up(1, 1) * yp.y();
    }
    // M^-1 = adj(M) / det: the products with adj(M) run beside the division.
    const double inv_det = 1.0 / (m00 * m11 - m01 * m01);
    const Eigen::Matrix2d& Un = upper[i];
    Eigen::Matrix2d& G = gain[i];
    G(0, 0) = (m11 * Un(0, 0) - m01 * Un(1, 0)) * inv_det;
    G(0, 1) = (m11 * Un(0, 1) - m01 * Un(1, 1)) * inv_det;
    G(1, 0) = (m00 * Un(1, 0) - m01 * Un(0, 0)) * inv_det;
    G(1, 1) = (m00 * Un(1, 1) - m01 * Un(0, 1)) * inv_det;
    rhs[i] = Eigen::Vector2d((m11 * y0 - m01 * y1) * inv_det, (m00 * y1 - m01 * y0) * inv_det);
  };
  auto eliminate_bottom = [&](int i) {
    const Eigen::Matrix2d& D = diag[i];
    double m00 = D(0, 0), m01 = D(0, 1), m11 = D(1, 1);
    const Eigen::Vector2d r = rhs[i] + explicit_rhs(i);
    double z0 = r.x(), z1 = r.y();
    if (i < last) {
      const Eigen::Matrix2d& Un = upper[i];
      const Eigen::Matrix2d& H = gain[i + 1];
      const Eigen::Vector2d& wn = rhs[i + 1];
      m00 -= Un(0, 0) * H(0, 0) + Un(0, 1) * H(1, 0);
      m01 -= Un(0, 0) * H(0, 1) + Un(0, 1) * H(1, 1);
      m11 -= Un(1, 0) * H(0, 1) + Un(1, 1) * H(1, 1);
      z0 -= Un(0, 0) * wn.x() + Un(0, 1) * wn.y();
      z1 -= Un(1, 0) * wn.x() + Un(1, 1) * wn.y();
    }
    const double inv_det = 1.0 / (m00 * m11 - m01 * m01);
    const Eigen::Matrix2d& Up = upper[i - 1];  // H_i = N_i^-1 U_(i-1)^T
    Eigen::Matrix2d& H = gain[i];
    H(0, 0) = (m11 * Up(0, 0) - m01 * Up(0, 1)) * inv_det;
    H(0, 1) = (m11 * Up(1, 0) - m01 * Up(1, 1)) * inv_det;
    H(1, 0) = (m00 * Up(0, 1) - m01 * Up(0, 0)) * inv_det;
    H(1, 1) = (m00 * Up(1, 1) - m01 * Up(1, 0)) * inv_det;
    rhs[i] = Eigen::Vector2d((m11 * z0 - m01 * z1) * inv_det, (m00 * z1 - m01 * z0) * inv_det);
  };
  for (int j = 0; j < last - p || j < p; ++j) {
    if (1 + j <= p) eliminate_top(1 + j);
    if (last - j > p) eliminate_bottom(last - j);
  }
  // Meet: x_p = y_p - G_p x_(p+1) and x_(p+1) = w_(p+1) - H_(p+1) x_p.
  if (last > p) {
    const Eigen::Matrix2d A = Eigen::Matrix2d::Identity() - gain[p] * gain[p + 1];
    const Eigen::Vector2d x_p = A.inverse() * (rhs[p] - gain[p] * rhs[p + 1]);
    rhs[p] = x_p;
    rhs[p + 1] -= gain[p + 1] * x_p;
  }
  // Substitute outward from the meeting point; rhs becomes the increments of d_i.
  for (int j = 1; p - j >= 1 || p + 1 + j <= last; ++j) {
    if (p - j >= 1) rhs[p - j].noalias() -= gain[p - j] * rhs[p - j + 1];
    if (p + 1 + j <= last) rhs[p + 1 + j].noalias() -= gain[p + 1 + j] * rhs[p + j];
  }
  const double inv_dt = 1.0 / dt;
  if (axial) SolveAxial(last, sc);
  for (int i = 1; i <= last; ++i) {
    s->colon_offset_m[i] += rhs[i];
    s->colon_rate_m_per_s[i] = rhs[i] * inv_dt;
    const Eigen::Vector2d& di = s->colon_offset_m[i];
    s->p_WColon[i] = pts[i].rest_position_m + di.x() * pts[i].plane_u + di.y() * pts[i].plane_v;
    if (axial) {
      s->colon_axial_m[i] += a_rhs[i];
      s->colon_axial_rate_m_per_s[i] = a_rhs[i] * inv_dt;
      s->p_WColon[i] += pts[i].rest_tangent * s->colon_axial_m[i];
    }
  }
  rhs[0].setZero();
  for (int i = last + 1; i < N; ++i) {
    rhs[i].setZero();
    s->colon_rate_m_per_s[i].setZero();
  }
  if (axial) {  // off, the axial arrays are never written and stay zero
    a_rhs[0] = 0.0;
    for (int i = last + 1; i < N; ++i) {
      a_rhs[i] = 0.0;
      s->colon_axial_rate_m_per_s[i] = 0.0;
    }
  }
}

}  // namespace ves::model::internal
