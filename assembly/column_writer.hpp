// Writes the 2x2 particle blocks of one column particle into a free-dof sparse matrix whose
// pattern came from build_pattern(): the scatter both the tangent and the preconditioner use.
// Gathering per column keeps assembly deterministic on any thread count (no atomics).
#pragma once

#include <algorithm>
#include <array>
#include <cstdlib>
#include <vector>

#include "assembly/pattern.hpp"
#include "discretisation/model.hpp"
#include "materials/family_kernel.hpp"

namespace peristat {

/// Writes 2x2 blocks (q, p) into the free-dof columns of particle p of a matrix with the
/// given pattern. One per thread; begin(p) prepares the column (zeroes it and fills a table
/// from lattice offset to row position), end() clears the table.
class ColumnWriter {
 public:
  ColumnWriter(const Model& model, const TangentPattern& pattern, SparseMatrix& A)
      : m_part(model.particles),
        m_cons(model.constraints),
        m_pat(pattern),
        m_reach(pattern.lattice_reach),
        m_width(2 * pattern.lattice_reach + 1),
        m_outer(A.outerIndexPtr()),
        m_values(A.valuePtr()),
        m_slot(static_cast<std::size_t>(m_width) * m_width, -1) {}

  /// False when p has no free component, or (a pattern of owned rows) no stored block:
  /// nothing to write.
  bool begin(Index p) {
    m_p = p;
    m_sign[0] = m_sign[1] = 1.0;
    m_col[0] = m_cons.free_index[2 * p];
    m_col[1] = m_cons.free_index[2 * p + 1];
    if (m_col[0] < 0 && m_col[1] < 0) return false;
    if (m_pat.col_start[p] == m_pat.col_start[p + 1]) return false;
    for (Index k = m_pat.col_start[p]; k < m_pat.col_start[p + 1]; ++k) slot(m_pat.row_particle[k]) = k;
    for (int c = 0; c < 2; ++c)
      if (m_col[c] >= 0) std::fill(m_values + m_outer[m_col[c]], m_values + m_outer[m_col[c] + 1], 0.0);
    return true;
  }
  void end() {
    for (Index k = m_pat.col_start[m_p]; k < m_pat.col_start[m_p + 1]; ++k) slot(m_pat.row_particle[k]) = -1;
  }
  /// From here to end(), blocks are the derivatives with respect to a mirror ghost of p
  /// (u_c(ghost) = sign[c] u_c(p) + const): column component c is scaled by sign[c].
  void fold_image(const std::array<double, 2>& sign) {
    m_sign[0] = sign[0];
    m_sign[1] = sign[1];
  }
  /// Adds the block a (row component, column component) at (q, p). Rows without a free
  /// component are dropped, and so are the rows that a pattern of owned rows does not store.
  void add(Index q, double a00, double a01, double a10, double a11) {
    const bool xr = m_cons.free_index[2 * q] >= 0, yr = m_cons.free_index[2 * q + 1] >= 0;
    if (!xr && !yr) return;
    if (m_pat.partial && !has(q)) return;
    const Index base = m_pat.row_offset[slot(q)];
    const double a[2][2] = {{a00, a01}, {a10, a11}};
    for (int cp = 0; cp < 2; ++cp) {
      if (m_col[cp] < 0) continue;
      double* v = m_values + m_outer[m_col[cp]] + base;
      if (xr) v[0] += m_sign[cp] * a[0][cp];
      if (yr) v[xr ? 1 : 0] += m_sign[cp] * a[1][cp];
    }
  }
  /// Whether the pattern holds the block (q, p) of the current column p.
  bool has(Index q) const {
    const auto& lq = m_part.lattice[q];
    const auto& lp = m_part.lattice[m_p];
    const int dx = lq[0] - lp[0], dy = lq[1] - lp[1];
    if (std::abs(dx) > m_reach || std::abs(dy) > m_reach) return false;
    return m_slot[static_cast<std::size_t>(dx + m_reach) * m_width + (dy + m_reach)] >= 0;
  }
  void add_sym(Index q, double scale, const Sym2& k) {
    add(q, scale * k[0], scale * k[1], scale * k[1], scale * k[2]);
  }
  void add_outer(Index q, double scale, const Vec2& a, const Vec2& b) {
    add(q, scale * a.x() * b.x(), scale * a.x() * b.y(), scale * a.y() * b.x(), scale * a.y() * b.y());
  }
  /// The block of a pair force g(u_other - u_p) or g(u_p - u_other) whose derivative with
  /// respect to u_p is S: +S at (p, p) and -S at (other, p) (docs/theory/contact.md, section 4).
  void add_pair(Index other, const Mat2& S) {
    add(m_p, S(0, 0), S(0, 1), S(1, 0), S(1, 1));
    add(other, -S(0, 0), -S(0, 1), -S(1, 0), -S(1, 1));
  }

 private:
  Index& slot(Index q) {
    const auto& lq = m_part.lattice[q];
    const auto& lp = m_part.lattice[m_p];
    return m_slot[static_cast<std::size_t>(lq[0] - lp[0] + m_reach) * m_width + (lq[1] - lp[1] + m_reach)];
  }

  const Particles& m_part;
  const Constraints& m_cons;
  const TangentPattern& m_pat;
  int m_reach, m_width;
  const Index* m_outer;
  double* m_values;
  std::vector<Index> m_slot;
  Index m_p = 0;
  Index m_col[2] = {-1, -1};
  double m_sign[2] = {1.0, 1.0};
};

}  // namespace peristat
