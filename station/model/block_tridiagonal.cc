// The colon's block-tridiagonal system solved by block Thomas elimination
// in O(N) (docs/model.md, "Time step" and "Speed").
#include "station/model/block_tridiagonal.h"

#include "station/model/internal.h"
#include "station/model/lanes.h"

namespace ves::model::internal {
namespace {

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
// triangle is formed and it is inverted by its adjugate, much faster than
// generic 3x3 products (docs/model.md, "Speed"). The sums are in the order
// of Eigen's 3x3 products (lanes.h), so the solution is bit for bit that of
// the same elimination with Eigen matrices.
//
// Two builds of the sweep, chosen when the program loads: with AVX2 a row
// of G, M or x is one vector (three lanes used), which takes about a fifth
// off the sweep; on the baseline x86-64 the same rows in two halves are
// twice as slow as scalars, so that build does one entry at a time. Both do
// every entry's operations in the same order: the same bits. (Outside the
// anonymous namespace: Clang counts only the default version's callers and
// would call the other unused.)
#if defined(__x86_64__) && !defined(VES_MODEL_BASELINE_ONLY)
#define VES_BASELINE_BUILD [[gnu::target("default")]]
#else
#define VES_BASELINE_BUILD
#endif
VES_BASELINE_BUILD void ForwardSweep(int last, ColonSystem* system) {
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
[[gnu::target("avx2")]] void ForwardSweep(int last, ColonSystem* system) {
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

void EliminateForward(int last, ColonSystem* system) { ForwardSweep(last, system); }

void SolveBlockTridiagonal(int last, ColonSystem* system) {
  ForwardSweep(last, system);
  Eigen::Vector3d x = system->Solution(last);
  for (int i = last - 1; i >= 1; --i) x = SubstituteBack(i, x, system);
}

}  // namespace ves::model::internal
