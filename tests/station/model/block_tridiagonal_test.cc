// The colon's block elimination (internal::SolveBlockTridiagonal, docs/model.md,
// "Time step"): it solves a symmetric positive definite block-tridiagonal
// system over points 1..last and leaves the held points alone.
#include <cmath>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "station/model/internal.h"

namespace ves::model {
namespace {

struct System {
  std::vector<Eigen::Matrix3d> diag, upper;
  std::vector<Eigen::Vector3d> rhs;
};

// Symmetric off-diagonal blocks and diagonal blocks that dominate them (so
// the whole matrix is positive definite), as SolveColon assembles them, but
// random.
System MakeSystem(int points, unsigned seed) {
  std::mt19937 random(seed);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  const auto random_matrix = [&] {
    Eigen::Matrix3d a;
    for (int k = 0; k < 9; ++k) a.data()[k] = unit(random);
    return a;
  };
  System s;
  for (int i = 0; i < points; ++i) {
    const Eigen::Matrix3d a = random_matrix();
    s.upper.push_back(0.5 * (a + a.transpose()));
    const Eigen::Matrix3d b = random_matrix();
    s.diag.push_back(6.0 * Eigen::Matrix3d::Identity() + b * b.transpose());
    s.rhs.emplace_back(unit(random), unit(random), unit(random));
  }
  return s;
}

// (A x)_i over points 1..last, with x_0 and the points past last held at 0.
Eigen::Vector3d ApplyRow(const System& s, const std::vector<Eigen::Vector3d>& x, int i, int last) {
  Eigen::Vector3d row = s.diag[i] * x[i];
  if (i > 1) row += s.upper[i - 1].transpose() * x[i - 1];
  if (i < last) row += s.upper[i] * x[i + 1];
  return row;
}

TEST(BlockTridiagonal, SolvesTheSystemAndLeavesTheHeldPointsAlone) {
  for (const int last : {1, 2, 7, 149}) {
    const System s = MakeSystem(last + 3, 17u + static_cast<unsigned>(last));
    // Into the solver's layout: D's upper triangle, U whole, one array each.
    const int points = static_cast<int>(s.diag.size());
    ColonSystem system;
    system.Resize(points);
    const int diag_entry[6][2] = {{0, 0}, {0, 1}, {0, 2}, {1, 1}, {1, 2}, {2, 2}};
    for (int i = 0; i < points; ++i) {
      for (int e = 0; e < 6; ++e) system.diag[e][i] = s.diag[i](diag_entry[e][0], diag_entry[e][1]);
      for (int e = 0; e < 9; ++e) system.upper[e][i] = s.upper[i](e / 3, e % 3);
      for (int c = 0; c < 3; ++c) system.rhs[c][i] = s.rhs[i][c];
    }
    // A mark in the solution's held points, which the solve must leave.
    const Eigen::Vector3d held(7.0, -8.0, 9.0);
    for (int i = 0; i < points; ++i) {
      for (int c = 0; c < 3; ++c) system.solution[4 * i + c] = held[c];
    }
    internal::SolveBlockTridiagonal(last, &system);
    std::vector<Eigen::Vector3d> x(points);
    for (int i = 0; i < points; ++i) x[i] = system.Solution(i);
    for (int i = 1; i <= last; ++i) {
      const Eigen::Vector3d residual = ApplyRow(s, x, i, last) - s.rhs[i];
      EXPECT_LT(residual.norm(), 1e-12 * s.rhs[i].norm() + 1e-14)
          << "point " << i << " of " << last;
    }
    // Point 0 and the points past `last` are not part of the solve.
    EXPECT_EQ(x[0], held);
    for (int i = last + 1; i < static_cast<int>(x.size()); ++i) EXPECT_EQ(x[i], held);
  }
}

}  // namespace
}  // namespace ves::model
