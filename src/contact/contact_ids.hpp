// The particle numbering that the contact rooms (candidate search, contact state, the
// ContactSystem facade) share: on a rank's part of the model (ModelPart) a particle's global
// id, whether this rank counts it, and the gathers over the ranks; on a whole model the ids
// are the identity, every particle is counted and a gather returns what it is given.
#pragma once

#include <cstdint>
#include <utility>
#include <vector>

#include "core/types.hpp"
#include "parallel/ranks.hpp"

namespace peristat {

/// A rank's share of the pairs when its model is its part of the whole (ModelPart;
/// docs/guide/distributed.md, "The partitioned model"). A part holds every pair that touches
/// one of its own particles (both ends are in the part: a partner lies within a horizon), with
/// i the end of the smaller global id, in the whole model's order; the pair is owned by the
/// rank that counts i. Counts, signature and checks are reduced over the ranks, so every rank
/// takes the same decisions. Empty (no global ids): the model is whole.
struct ContactRanks {
  std::vector<std::int64_t> global_id;  ///< per particle of the part: its index in the whole model
  std::vector<char> counted;  ///< per particle: this rank's own (the forces it adds, the pairs it owns)
  std::int64_t n_particles_whole = 0;
};

/// Global ids of a model's particles: ContactRanks' on a part, the identity on a whole model.
class ContactIds {
 public:
  /// `n` particles in the model; on a part, the collectives over `ranks`. Throws
  /// std::logic_error when a part misses a global id or a counted flag per particle.
  ContactIds(ContactRanks share, Index n, const Ranks& ranks);

  /// A rank's part of the model (ContactRanks given).
  bool partitioned() const { return !m_share.global_id.empty(); }
  /// The particle's index in the whole model.
  std::int64_t gid(Index i) const {
    return partitioned() ? m_share.global_id[static_cast<std::size_t>(i)] : i;
  }
  /// This rank's own particle (every particle of a whole model).
  bool counted(Index i) const { return !partitioned() || m_share.counted[static_cast<std::size_t>(i)]; }
  /// The particle with global id g, or -1 when the model does not hold it.
  Index local_of(std::int64_t g) const;
  /// Particles in the whole model.
  std::int64_t n_particles_whole() const { return partitioned() ? m_share.n_particles_whole : m_n; }

  /// Every rank's `mine` concatenated in rank order, on every rank (collective on a part;
  /// `mine` itself on a whole model, which every rank holds alike).
  template <class T>
  std::vector<T> gather(const std::vector<T>& mine) const {
    return partitioned() ? m_ranks.all_gather(mine) : mine;
  }
  /// The largest of a value, and the sum, over the ranks (collective on a part).
  double max_over_ranks(double value) const { return partitioned() ? m_ranks.max(value) : value; }
  std::int64_t sum_over_ranks(std::int64_t value) const { return partitioned() ? m_ranks.sum(value) : value; }
  /// Rows of `width` values by global id into a table of n_rows rows, on rank 0 (collective on
  /// a part; empty on the other ranks).
  std::vector<double> gather_on_root(const std::vector<std::int64_t>& ids, const std::vector<double>& values,
                                     int width, std::int64_t n_rows) const;

 private:
  ContactRanks m_share;
  const Ranks& m_ranks;
  Index m_n = 0;
  std::vector<std::pair<std::int64_t, Index>> m_by_global;  ///< on a part: (global id, particle), sorted
};

}  // namespace peristat
