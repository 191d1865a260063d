// Basic numeric types shared by every target.
#pragma once

#include <cstdint>

#include <Eigen/Core>
#include <Eigen/SparseCore>

namespace peristat {

using Index = std::int32_t;  // particle, bond and dof indices (fits 2^31 unknowns)
using Vec2 = Eigen::Vector2d;
using Mat2 = Eigen::Matrix2d;
using VectorXd = Eigen::VectorXd;
/// A read-only vector argument that a VectorXd or a column of a column-major matrix (a Krylov
/// basis vector) binds to without a copy: a `const VectorXd&` parameter given a column makes a
/// temporary, which at 1.3 MB is an mmap, 313 page faults and an munmap per call.
using VectorIn = Eigen::Ref<const VectorXd>;
using SparseMatrix = Eigen::SparseMatrix<double, Eigen::ColMajor, Index>;

/// Empties `m` and gives its storage back: assigning an empty matrix keeps the allocation
/// (Eigen 3.4's CompressedStorage only clears its size).
inline void release(SparseMatrix& m) {
  SparseMatrix empty;
  m.swap(empty);
}

/// m = from without a copy: Eigen 3.4's SparseMatrix has no move assignment, so `m = f()`
/// copies every entry (52 million for the bond matrix at 1000 x 1000). m's old storage goes
/// with `from`.
inline void take(SparseMatrix& m, SparseMatrix&& from) {
  m.swap(from);
}

}  // namespace peristat
