// Sparsity pattern of the tangent, built once from the bond stencils.
// Particle p couples to every particle within two horizons through the dilatation: the
// rows of column particle p are the union of the families of p and of its neighbours.
#pragma once

#include <vector>

#include "contact/contact.hpp"
#include "discretisation/model.hpp"

namespace peristat {

/// Particle-level column structure plus the map to the free-dof matrix.
struct TangentPattern {
  // Column particle p couples to row particles row_particle[col_start[p] .. col_start[p+1]-1],
  // ascending. row_offset[k] is the position, within a free-dof column of p, of the first
  // free dof of row particle row_particle[k].
  std::vector<Index> col_start;
  std::vector<Index> row_particle;
  std::vector<Index> row_offset;
  int lattice_reach = 0;   ///< max lattice offset between coupled particles
  long long nonzeros = 0;  ///< of the free-dof matrix

  /// A free-dof matrix with this pattern (values zero), column-major, rows ascending in each
  /// column. O(nonzeros); the structure above is what is expensive to build.
  SparseMatrix make_matrix(const Constraints& constraints) const;
  /// Bytes of one matrix from make_matrix() (values and row indices).
  std::size_t matrix_bytes() const;
  /// Bytes of the structure itself.
  std::size_t memory_bytes() const;
};

/// PatternReach::bonds_within takes bonds of length up to the radius with this relative
/// margin for lattice round-off; the bond preconditioner's values use the same test.
inline constexpr double kBondRadiusMargin = 1e-9;

/// Which couplings the pattern holds.
enum class PatternReach {
  two_horizons,  ///< the OSB tangent: families of p and of its neighbours
  bonds_within,  ///< bond pairs of length <= a given radius only
};

/// Builds the pattern's structure. Deterministic; O(N n^2) with n the family size.
/// `radius` [m] is used with PatternReach::bonds_within only. The candidate pairs of
/// `contact`, when given, are coupled too.
TangentPattern build_pattern(const Model& model, PatternReach reach = PatternReach::two_horizons,
                             double radius = 0.0, const ContactSystem* contact = nullptr);

}  // namespace peristat
