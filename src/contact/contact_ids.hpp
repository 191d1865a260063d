// The particle numbering that the contact rooms (candidate search, contact state, the
// ContactSystem facade) share: on a rank's part of the model (ModelPart) a particle's global
// id, whether this rank counts it, and the gathers over the ranks; on a whole model the ids
// are the identity, every particle is counted and a gather returns what it is given.
#pragma once

#include <cstdint>
#include <functional>
#include <utility>
#include <vector>

#include "core/partition.hpp"
#include "core/types.hpp"

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
  GatherOverRanks gather;  ///< every rank's values in rank order, on every rank (collective)
  /// Rows by global id to rank 0 (parallel::gather_rows_on_root: collective; empty elsewhere).
  std::function<std::vector<double>(const std::vector<std::int64_t>& ids, const std::vector<double>& values,
                                    int width, std::int64_t n_rows)>
      gather_on_root;
};

/// Global ids of a model's particles: ContactRanks' on a part, the identity on a whole model.
class ContactIds {
 public:
  /// `n` particles in the model. Throws std::logic_error when a part misses a global id or a
  /// counted flag per particle, or one of the gathers.
  ContactIds(ContactRanks ranks, Index n);

  /// A rank's part of the model (ContactRanks given).
  bool partitioned() const { return !m_ranks.global_id.empty(); }
  /// The particle's index in the whole model.
  std::int64_t gid(Index i) const {
    return partitioned() ? m_ranks.global_id[static_cast<std::size_t>(i)] : i;
  }
  /// This rank's own particle (every particle of a whole model).
  bool counted(Index i) const { return !partitioned() || m_ranks.counted[static_cast<std::size_t>(i)]; }
  /// The particle with global id g, or -1 when the model does not hold it.
  Index local_of(std::int64_t g) const;
  /// Particles in the whole model.
  std::int64_t n_particles_whole() const { return partitioned() ? m_ranks.n_particles_whole : m_n; }

  /// Every rank's `mine` concatenated in rank order, on every rank (collective; `mine` itself
  /// on a whole model).
  std::vector<double> gather(const std::vector<double>& mine) const;
  /// The largest of a value over the ranks (collective).
  double max_over_ranks(double value) const;
  /// Rows of `width` values by global id into a table of n_rows rows, on rank 0 (collective;
  /// empty on the other ranks).
  std::vector<double> gather_on_root(const std::vector<std::int64_t>& ids, const std::vector<double>& values,
                                     int width, std::int64_t n_rows) const;
  /// The rows of `width` values that gather() returned, in the whole model's order (their
  /// offsets into `all`): a whole model's rows are already in its order; the parts' rows, in
  /// rank order, are sorted by the global ids in their first two values.
  std::vector<std::size_t> rows_in_whole_order(const std::vector<double>& all, std::size_t width) const;

 private:
  ContactRanks m_ranks;
  Index m_n = 0;
  std::vector<std::pair<std::int64_t, Index>> m_by_global;  ///< on a part: (global id, particle), sorted
};

}  // namespace peristat
