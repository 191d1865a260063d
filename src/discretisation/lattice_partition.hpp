// Which rank owns which lattice point: the lattice box cut into one region per rank by
// recursive bisection of the census's nodes (the particles with an unknown), so that every
// rank computes the same regions from the census alone and no table of owners is held
// (docs/guide/distributed.md, "Who owns what"). Nothing about MPI here.
#pragma once

#include <array>
#include <vector>

#include "core/options.hpp"
#include "discretisation/census.hpp"

namespace peristat {

/// A box of lattice points [lo, hi] (inclusive).
struct LatticeBox {
  std::array<int, 2> lo{0, 0}, hi{-1, -1};
  bool contains(int i, int j) const { return i >= lo[0] && i <= hi[0] && j >= lo[1] && j <= hi[1]; }
};

class LatticePartition {
 public:
  /// `parts` regions tiling the census box, each holding an equal share of the nodes to
  /// within one lattice line: cut across the longer extent of each box's nodes (`rcb`) or
  /// always across x (`strips`: slabs of columns).
  LatticePartition(const LatticeCensus& census, int parts, BelosPartition kind);

  int parts() const { return static_cast<int>(m_region.size()); }
  const LatticeBox& region(int part) const { return m_region[static_cast<std::size_t>(part)]; }
  /// The region holding lattice point (i, j) (a point outside the census box: the nearest).
  int region_at(int i, int j) const;
  /// The rank owning the particle at (i, j): its region's, a mirror ghost its source's (a
  /// ghost's displacement is its source's image).
  int owner(int i, int j) const;

 private:
  struct Cut {
    int axis = -1;   ///< -1: a leaf
    int at = 0;      ///< points with coordinate <= at go left
    int left = -1, right = -1;
    int part = 0;    ///< a leaf's region
  };
  const LatticeCensus& m_census;
  std::vector<Cut> m_tree;  ///< m_tree[0] the root
  std::vector<LatticeBox> m_region;

  int bisect(const LatticeBox& box, int first_part, int n_parts, BelosPartition kind);
};

}  // namespace peristat
