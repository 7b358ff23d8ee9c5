#pragma once

// The block Thomas elimination of the colon's system (block_tridiagonal.cc);
// internal to station/model.
#include <Eigen/Core>

#include "station/model/model.h"

namespace ves::model::internal {

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

// The forward sweep of the block Thomas elimination over points 1..last
// (block_tridiagonal.cc says how): y_i into solution, G_i into gain.
void EliminateForward(int last, ColonSystem* system);

}  // namespace ves::model::internal
