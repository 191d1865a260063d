// The lattice census: which lattice point holds which particle, as a few bytes per point, and
// the scene's checks made on it. A model or a rank's part of one is built from the census
// (discretisation/model.hpp), so that no process ever holds a particle table for particles it
// does not keep (docs/guide/distributed.md, "The partitioned model").
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "core/description.hpp"
#include "core/types.hpp"
#include "discretisation/model.hpp"

namespace peristat {

/// One lattice point: the group that created its particle (0: no particle; a body's own
/// particles are group b + 1, the fictitious particles a condition k created group
/// n_bodies + k + 1), the condition prescribing each component (0: free; condition k + 1) and,
/// when counted, its family's size.
struct CensusPoint {
  std::uint16_t group = 0;
  std::array<std::uint16_t, 2> prescribed_by{0, 0};
  std::uint16_t family = 0;
  bool exists() const { return group != 0; }
  bool node() const { return exists() && (prescribed_by[0] == 0 || prescribed_by[1] == 0); }
  int free_components() const { return (prescribed_by[0] == 0) + (prescribed_by[1] == 0); }
};

/// The scene on its lattice. Particles are numbered in the order they are created: the groups
/// in order, and within a group by lattice point (i, then j). That numbering (a particle's
/// global id), the unknowns' (the free components in particle order) and the bonds' (families
/// in particle order) are the whole model's, on every process alike.
class LatticeCensus {
 public:
  int i0 = 0, j0 = 0, ni = 0, nj = 0;  ///< the box [i0, i0 + ni) x [j0, j0 + nj)
  std::vector<CensusPoint> point;      ///< ni * nj, i-major
  int n_bodies = 0;
  std::vector<int> group_body;         ///< per group g (>= 1): the body of its particles
  /// Per condition: the axis of its mirror line's normal (-1: not a mirror) and the line's
  /// lattice index (the line x = origin + line * dx for axis 0).
  std::vector<int> mirror_axis;
  std::vector<long> mirror_line;
  /// Per group (index 0 unused): particles, free components and (families counted) bonds.
  std::vector<std::int64_t> group_particles, group_free, group_bonds;
  bool families_counted = false;
  std::int64_t n_cut_bonds = 0;  ///< with families_counted: pairs cut by pre-cracks
  Stencil stencil;
  double spacing = 0.0;
  Vec2 origin = Vec2::Zero();

  bool inside(int i, int j) const { return i >= i0 && j >= j0 && i < i0 + ni && j < j0 + nj; }
  std::size_t linear(int i, int j) const {
    return static_cast<std::size_t>(i - i0) * static_cast<std::size_t>(nj) + static_cast<std::size_t>(j - j0);
  }
  /// The point at (i, j); an empty one outside the box.
  CensusPoint at(int i, int j) const { return inside(i, j) ? point[linear(i, j)] : CensusPoint{}; }
  bool fictitious(const CensusPoint& p) const { return p.group > n_bodies; }
  int body(const CensusPoint& p) const { return group_body[p.group]; }
  Vec2 position(int i, int j) const { return origin + Vec2((i + 0.5) * spacing, (j + 0.5) * spacing); }
  /// The lattice point a mirror ghost at (i, j) reflects, or false when (i, j) is no ghost.
  bool source_of(int i, int j, std::array<int, 2>& source) const;

  std::int64_t n_particles() const;
  std::int64_t n_unknowns() const;
  std::int64_t n_bonds() const;  ///< with families_counted
  std::size_t memory_bytes() const { return point.capacity() * sizeof(CensusPoint); }
};

/// The census of `scene`: every particle placed, every condition's particles selected and
/// its components assigned, with the checks discretise() documents (InputError with the
/// condition's or body's location). With `count_families`, each point's family size and the
/// cut pairs (a rank's part numbers its bonds as the whole model's).
LatticeCensus take_census(const ModelDescription& scene, bool count_families);

}  // namespace peristat
