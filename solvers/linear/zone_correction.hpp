// A zone's exact correction after a preconditioner (docs/theory/newton.md, "The contact
// zone's exact correction"): after z = M^-1 v (the V-cycle), z += E P_zz^-1 E^T (v - P z),
// E the zone's unknowns and P_zz its block of P. One block Gauss-Seidel step on the zone:
// the rows of P the V-cycle serves worst (the contact pairs' and the crack flanks') then hold
// exactly, at P's values of the current state.
#pragma once

#include <vector>

#include <Eigen/SparseCholesky>

#include "core/types.hpp"

namespace peristat {

class ZoneCorrection {
 public:
  /// From Pz, a square matrix whose non-empty rows are the zone's rows of a symmetric P:
  /// keeps them and factors P_zz (Eigen's SimplicialLDLT). While Pz's pattern is the last
  /// one's (the same zone at another contact state) its values are copied in place and only
  /// the numeric factorisation is done again: no allocation, no symbolic analysis. False,
  /// and no correction, when Pz has no row or P_zz's factor fails.
  bool set(const SparseMatrix& Pz);
  void clear() { m_rows.clear(); }
  bool active() const { return !m_rows.empty(); }
  /// The zone's unknowns.
  Index size() const { return static_cast<Index>(m_rows.size()); }
  /// z += E P_zz^-1 E^T (v - P z): the zone's rows of P z on the threads, then the factor's
  /// solve. No allocation after the first call at a size.
  void apply(VectorIn v, VectorXd& z);

 private:
  using RowMatrix = Eigen::SparseMatrix<double, Eigen::RowMajor, Index>;
  std::vector<Index> m_rows;  ///< the zone's unknowns, ascending
  RowMatrix m_P;              ///< P's rows of the zone (all columns)
  SparseMatrix m_Pzz;
  Eigen::SimplicialLDLT<SparseMatrix, Eigen::Lower> m_ldlt;
  /// The pattern of the last Pz built from (empty: none), and for each entry of m_P and
  /// m_Pzz the position in Pz's values it copies.
  std::vector<Index> m_pattern_outer, m_pattern_inner;
  std::vector<std::size_t> m_P_from, m_Pzz_from;
  VectorXd m_r, m_d;
  bool same_pattern(const SparseMatrix& Pz) const;
  /// m_P's and m_Pzz's values from Pz's (same_pattern()).
  void refill(const SparseMatrix& Pz);
  /// The zone's rows, m_P, m_Pzz, the positions and P_zz's symbolic analysis from Pz.
  void build(const SparseMatrix& Pz);
};

}  // namespace peristat
