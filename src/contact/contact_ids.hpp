// The particle numbering that the contact rooms (candidate search, contact state, the
// ContactSystem facade) share: on a rank's part of the model (ModelPart) a particle's global
// id, whether this rank counts it, and the gathers over the ranks; on a whole model the ids
// are the identity, every particle is counted and a gather returns what it is given.
#pragma once

#include <cstdint>
#include <span>
#include <utility>
#include <vector>

#include "core/global_ids.hpp"
#include "core/types.hpp"
#include "parallel/ranks.hpp"

namespace peristat {

/// A rank's share of the pairs when its model is its part of the whole (ModelPart;
/// docs/guide/distributed.md, "The partitioned model"). A part holds every pair that touches
/// one of its own particles (both ends are in the part: a partner lies within a horizon), with
/// i the end of the smaller global id, in the whole model's order; the pair is owned by the
/// rank that counts i. Counts, signature and checks are reduced over the ranks, so every rank
/// takes the same decisions. Empty (no global ids): the model is whole, and ContactIds makes
/// its identity numbering.
struct ContactRanks {
  const GlobalIds* ids = nullptr;  ///< the part's particles in the whole model (owned by the caller)
  std::vector<char> counted;  ///< per particle: this rank's own (the forces it adds, the pairs it owns)
};

/// Global ids of a model's particles: ContactRanks' on a part, the identity on a whole model
/// (one rank's; its collectives return what they are given). The contact rooms read the ids
/// and call the collectives alike either way.
class ContactIds {
 public:
  /// `n` particles in the model; on a part, the collectives over `ranks`. Throws
  /// std::logic_error when a part misses a global id or a counted flag per particle, or when a
  /// whole model (no global ids) is given more than one rank.
  ContactIds(ContactRanks share, Index n, const Ranks& ranks);

  /// Every particle of the whole model is here (a whole model, or a part that took in all):
  /// no partner can be missing.
  bool holds_every_particle() const { return ids().holds_every_particle(); }
  /// The particle's index in the whole model.
  std::int64_t gid(Index i) const { return ids()[i]; }
  /// This rank's own particle (every particle of a whole model).
  bool counted(Index i) const { return m_share.counted[static_cast<std::size_t>(i)] != 0; }
  /// The particle with global id g, or -1 when the model does not hold it.
  Index local_of(std::int64_t g) const { return ids().local_of(g); }
  /// Particles in the whole model.
  std::int64_t n_particles_whole() const { return ids().n_whole(); }

  /// Every rank's `mine` concatenated in rank order, on every rank (collective).
  template <class T>
  std::vector<T> gather(const std::vector<T>& mine) const {
    return m_ranks.all_gather(mine);
  }
  /// The largest of a value, and the sum, over the ranks (collective).
  double max_over_ranks(double value) const { return m_ranks.max(value); }
  std::int64_t sum_over_ranks(std::int64_t value) const { return m_ranks.sum(value); }
  /// Rows of `width` values by global id into a table of n_rows rows, on rank 0 (collective;
  /// empty on the other ranks).
  std::vector<double> gather_on_root(const std::vector<std::int64_t>& ids, const std::vector<double>& values,
                                     int width, std::int64_t n_rows) const {
    return m_ranks.gather_rows_on_root(std::span<const std::int64_t>(ids), std::span<const double>(values), width,
                                       n_rows);
  }

 private:
  ContactRanks m_share;
  const Ranks& m_ranks;
  GlobalIds m_own;  ///< a whole model's identity numbering (no ContactRanks::ids)
  const GlobalIds& ids() const { return m_share.ids ? *m_share.ids : m_own; }
};

}  // namespace peristat
