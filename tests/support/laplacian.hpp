// Small SPD matrices for the linear solvers' unit tests (unit/test_stop.cpp,
// unit/test_krylov_products.cpp, unit/test_zone_correction.cpp): the 1D and 2D Laplacians
// with springs to the ground at the ends.
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

/// The 5-point Laplacian of an m x m grid (4 on the diagonal, -1 to each grid neighbour),
/// unknown i + m j at grid point (i, j).
inline SparseMatrix laplacian_2d(Index m) {
  std::vector<Eigen::Triplet<double, Index>> t;
  for (Index j = 0; j < m; ++j)
    for (Index i = 0; i < m; ++i) {
      const Index k = i + m * j;
      t.emplace_back(k, k, 4.0);
      if (i > 0) t.emplace_back(k, k - 1, -1.0);
      if (i + 1 < m) t.emplace_back(k, k + 1, -1.0);
      if (j > 0) t.emplace_back(k, k - m, -1.0);
      if (j + 1 < m) t.emplace_back(k, k + m, -1.0);
    }
  SparseMatrix A(m * m, m * m);
  A.setFromTriplets(t.begin(), t.end());
  return A;
}

}  // namespace peristat::test
