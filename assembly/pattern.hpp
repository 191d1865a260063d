// Sparsity pattern of the tangent, built once from the bond stencils.
// Particle p couples to every particle within two horizons through the dilatation: the
// rows of column particle p are the union of the families of p and of its neighbours.
#pragma once

#include <algorithm>
#include <vector>

#include "contact/contact.hpp"
#include "discretisation/model.hpp"

namespace peristat {

/// The rows that one rank of a distributed run assembles (docs/guide/distributed.md): those
/// of the particles whose owner is `rank`. The default (no owners) holds every row (one
/// process).
/// Whether rank `rank` counts a particle whose rows rank `owner` owns (-1: none) in a sum over
/// the ranks: its owner does, and rank 0 counts a particle without an owner (every rank holds
/// those alike), so that every particle is counted once.
inline bool counted_by(int owner, int rank) {
  return owner == rank || (owner < 0 && rank == 0);
}

struct OwnedRows {
  int rank = 0;
  std::vector<int> owner;  ///< per particle, the rank that owns its rows (-1: it has none); empty: all here
  bool all() const { return owner.empty(); }
  /// Every row is this rank's: all(), or a one-rank part.
  bool whole() const {
    return std::all_of(owner.begin(), owner.end(), [this](int o) { return o == rank; });
  }
  bool contains(Index p) const { return owner.empty() || owner[static_cast<std::size_t>(p)] == rank; }
  /// counted_by() for particle p; every particle when all().
  bool counts(Index p) const { return owner.empty() || counted_by(owner[static_cast<std::size_t>(p)], rank); }
  /// This rank computes particle p's forces: its own, and those without an owner (every rank
  /// computes those alike); every particle when all().
  bool computes(Index p) const {
    return owner.empty() || owner[static_cast<std::size_t>(p)] == rank || owner[static_cast<std::size_t>(p)] < 0;
  }
};

/// Particle-level column structure plus the map to the free-dof matrix.
struct TangentPattern {
  // Column particle p couples to row particles row_particle[col_start[p] .. col_start[p+1]-1],
  // ascending. row_offset[k] is the position, within a free-dof column of p, of the first
  // free dof of row particle row_particle[k].
  std::vector<Index> col_start;
  std::vector<Index> row_particle;
  std::vector<Index> row_offset;
  int lattice_reach = 0;   ///< max lattice offset between coupled particles (of the stored blocks)
  long long nonzeros = 0;  ///< of the free-dof matrix
  /// Built for OwnedRows other than all(): only those rows are stored, and a column may be
  /// empty. Columns outside [col_first, col_end) are empty in any case.
  bool partial = false;
  Index col_first = 0, col_end = 0;

  /// Whether the pattern stores the block (row particle q, column particle p).
  bool holds(Index q, Index p) const {
    const auto begin = row_particle.begin() + col_start[p], end = row_particle.begin() + col_start[p + 1];
    return std::binary_search(begin, end, q);
  }
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
/// `contact`, when given, are coupled too. With `owned` rows, only they are stored (each
/// column's blocks in owned rows, in the same order as in the whole pattern), and the work is
/// that of the owned columns and of the columns within reach of them.
TangentPattern build_pattern(const Model& model, PatternReach reach = PatternReach::two_horizons,
                             double radius = 0.0, const ContactSystem* contact = nullptr,
                             const OwnedRows& owned = {});

}  // namespace peristat
