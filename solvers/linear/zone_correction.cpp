#include "solvers/linear/zone_correction.hpp"

#include <algorithm>

namespace peristat {

bool ZoneCorrection::set(const SparseMatrix& Pz) {
  m_rows.clear();
  m_P = Pz;  // by rows: the zone's rows are the non-empty ones
  const Index n = static_cast<Index>(m_P.rows());
  const Index* row_start = m_P.outerIndexPtr();
  std::vector<Index> local(static_cast<std::size_t>(n), -1);
  for (Index i = 0; i < n; ++i)
    if (row_start[i + 1] > row_start[i]) {
      local[i] = static_cast<Index>(m_rows.size());
      m_rows.push_back(i);
    }
  const Index nz = size();
  if (nz == 0) return false;
  std::vector<Eigen::Triplet<double, Index>> entries;
  entries.reserve(static_cast<std::size_t>(m_P.nonZeros()));
  for (Index r = 0; r < nz; ++r)
    for (RowMatrix::InnerIterator it(m_P, m_rows[r]); it; ++it)
      if (local[it.col()] >= 0) entries.emplace_back(r, local[it.col()], it.value());
  m_Pzz.resize(nz, nz);
  m_Pzz.setFromTriplets(entries.begin(), entries.end());
  const Index* outer = m_Pzz.outerIndexPtr();
  const Index* inner = m_Pzz.innerIndexPtr();
  const bool same_pattern = m_outer.size() == static_cast<std::size_t>(nz + 1) &&
                            m_inner.size() == static_cast<std::size_t>(m_Pzz.nonZeros()) &&
                            std::equal(m_outer.begin(), m_outer.end(), outer) &&
                            std::equal(m_inner.begin(), m_inner.end(), inner);
  if (!same_pattern) {
    m_ldlt.analyzePattern(m_Pzz);
    m_outer.assign(outer, outer + nz + 1);
    m_inner.assign(inner, inner + m_Pzz.nonZeros());
  }
  m_ldlt.factorize(m_Pzz);
  if (m_ldlt.info() != Eigen::Success) {
    m_rows.clear();
    m_outer.clear();  // analyse afresh next time
    return false;
  }
  m_r.resize(nz);
  m_d.resize(nz);
  return true;
}

void ZoneCorrection::apply(VectorIn v, VectorXd& z) {
  const Index nz = size();
  if (nz == 0) return;
#pragma omp parallel for schedule(static)
  for (Index r = 0; r < nz; ++r) {
    double s = 0.0;
    for (RowMatrix::InnerIterator it(m_P, m_rows[r]); it; ++it) s += it.value() * z[it.col()];
    m_r[r] = v[m_rows[r]] - s;
  }
  m_d = m_ldlt.solve(m_r);
  for (Index r = 0; r < nz; ++r) z[m_rows[r]] += m_d[r];
}

}  // namespace peristat
