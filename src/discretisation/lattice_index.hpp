// The one map from integer lattice coordinates to particle numbers (discretisation builds
// it with the particles; contact search and anything else that looks up a lattice
// neighbour reads it from the Model).
#pragma once

#include <cstddef>
#include <vector>

#include "core/types.hpp"

namespace peristat {

/// Dense index over the lattice box [i0, i1] x [j0, j1]; -1 where no particle sits.
class LatticeIndex {
 public:
  LatticeIndex() = default;
  LatticeIndex(int i0, int j0, int i1, int j1)
      : m_i0(i0),
        m_j0(j0),
        m_ni(i1 - i0 + 1),
        m_nj(j1 - j0 + 1),
        m_cell(static_cast<std::size_t>(m_ni) * m_nj, -1) {}

  /// The particle at lattice point (i, j), or -1 (also outside the box).
  Index at(int i, int j) const {
    if (i < m_i0 || j < m_j0 || i >= m_i0 + m_ni || j >= m_j0 + m_nj) return -1;
    return m_cell[static_cast<std::size_t>(i - m_i0) * m_nj + (j - m_j0)];
  }
  /// (i, j) must lie inside the box.
  void set(int i, int j, Index p) { m_cell[static_cast<std::size_t>(i - m_i0) * m_nj + (j - m_j0)] = p; }

  std::size_t memory_bytes() const { return m_cell.capacity() * sizeof(Index); }

 private:
  int m_i0 = 0, m_j0 = 0, m_ni = 0, m_nj = 0;
  std::vector<Index> m_cell;
};

}  // namespace peristat
