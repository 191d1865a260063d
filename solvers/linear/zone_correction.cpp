#include "solvers/linear/zone_correction.hpp"

#include <algorithm>

namespace peristat {

bool ZoneCorrection::set(const SparseMatrix& Pz_given) {
  SparseMatrix compressed;  // positions are those of a compressed Pz (the system's already is)
  if (!Pz_given.isCompressed()) {
    compressed = Pz_given;
    compressed.makeCompressed();
  }
  const SparseMatrix& Pz = Pz_given.isCompressed() ? Pz_given : compressed;
  if (same_pattern(Pz)) {
    refill(Pz);
  } else {
    build(Pz);
    if (size() == 0) return false;
  }
  m_ldlt.factorize(m_Pzz);
  if (m_ldlt.info() != Eigen::Success) {
    clear();
    m_pattern_outer.clear();  // build and analyse afresh next time
    return false;
  }
  return true;
}

bool ZoneCorrection::same_pattern(const SparseMatrix& Pz) const {
  if (m_rows.empty() || m_pattern_outer.size() != static_cast<std::size_t>(Pz.outerSize()) + 1 ||
      m_pattern_inner.size() != static_cast<std::size_t>(Pz.nonZeros()))
    return false;
  return std::equal(m_pattern_outer.begin(), m_pattern_outer.end(), Pz.outerIndexPtr()) &&
         std::equal(m_pattern_inner.begin(), m_pattern_inner.end(), Pz.innerIndexPtr());
}

void ZoneCorrection::refill(const SparseMatrix& Pz) {
  const double* from = Pz.valuePtr();
  double* p = m_P.valuePtr();
  for (std::size_t k = 0; k < m_P_from.size(); ++k) p[k] = from[m_P_from[k]];
  double* pzz = m_Pzz.valuePtr();
  for (std::size_t k = 0; k < m_Pzz_from.size(); ++k) pzz[k] = from[m_Pzz_from[k]];
}

void ZoneCorrection::build(const SparseMatrix& Pz) {
  // The rows and the zone's block made from a copy of Pz whose values are their own positions
  // in Pz (exact in double): afterwards each kept entry knows the entry of Pz it copies, and
  // a Pz of the same pattern (the same zone at another active set) is copied in place.
  m_rows.clear();
  SparseMatrix positions = Pz;
  for (Index k = 0; k < positions.nonZeros(); ++k) positions.valuePtr()[k] = static_cast<double>(k);
  m_P = positions;  // by rows: the zone's rows are the non-empty ones
  const Index n = static_cast<Index>(m_P.rows());
  const Index* row_start = m_P.outerIndexPtr();
  std::vector<Index> local(static_cast<std::size_t>(n), -1);
  for (Index i = 0; i < n; ++i)
    if (row_start[i + 1] > row_start[i]) {
      local[i] = static_cast<Index>(m_rows.size());
      m_rows.push_back(i);
    }
  const Index nz = size();
  if (nz == 0) return;
  std::vector<Eigen::Triplet<double, Index>> entries;
  entries.reserve(static_cast<std::size_t>(m_P.nonZeros()));
  for (Index r = 0; r < nz; ++r)
    for (RowMatrix::InnerIterator it(m_P, m_rows[r]); it; ++it)
      if (local[it.col()] >= 0) entries.emplace_back(r, local[it.col()], it.value());
  m_Pzz.resize(nz, nz);
  m_Pzz.setFromTriplets(entries.begin(), entries.end());
  const auto position = [](double v) { return static_cast<std::size_t>(v); };
  m_P_from.resize(static_cast<std::size_t>(m_P.nonZeros()));
  for (Index k = 0; k < m_P.nonZeros(); ++k) m_P_from[k] = position(m_P.valuePtr()[k]);
  m_Pzz_from.resize(static_cast<std::size_t>(m_Pzz.nonZeros()));
  for (Index k = 0; k < m_Pzz.nonZeros(); ++k) m_Pzz_from[k] = position(m_Pzz.valuePtr()[k]);
  m_pattern_outer.assign(positions.outerIndexPtr(), positions.outerIndexPtr() + positions.outerSize() + 1);
  m_pattern_inner.assign(positions.innerIndexPtr(), positions.innerIndexPtr() + positions.nonZeros());
  refill(Pz);
  m_ldlt.analyzePattern(m_Pzz);
  m_r.resize(nz);
  m_d.resize(nz);
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
