// The 1D Laplacian with a spring to the ground at each end (2 on the diagonal, -1 beside it):
// a small SPD matrix for the linear solvers' unit tests (unit/test_stop.cpp,
// unit/test_krylov_products.cpp).
#pragma once

#include <vector>

#include "core/types.hpp"

namespace peristat::test {

inline SparseMatrix laplacian_1d(Index n) {
  std::vector<Eigen::Triplet<double, Index>> t;
  for (Index i = 0; i < n; ++i) {
    t.emplace_back(i, i, 2.0);
    if (i > 0) t.emplace_back(i, i - 1, -1.0);
    if (i + 1 < n) t.emplace_back(i, i + 1, -1.0);
  }
  SparseMatrix A(n, n);
  A.setFromTriplets(t.begin(), t.end());
  return A;
}

}  // namespace peristat::test
