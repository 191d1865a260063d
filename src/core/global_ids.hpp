// A model's particles by their numbers in the whole model (a rank's part, docs/guide/
// distributed.md; or the whole model, numbered by itself): the one map from a global id back
// to the part's particle, built once per problem and read by contact and failure alike.
#pragma once

#include <cstdint>
#include <utility>
#include <vector>

#include "core/types.hpp"

namespace peristat {

class GlobalIds {
 public:
  GlobalIds() = default;
  /// A whole model of n particles, numbered by itself (no map is built).
  explicit GlobalIds(Index n);
  /// A part: ids[i] is particle i's number in a whole model of n_whole particles. Throws
  /// std::logic_error for an id outside [0, n_whole) or one given twice.
  GlobalIds(std::vector<std::int64_t> ids, std::int64_t n_whole);

  Index size() const { return static_cast<Index>(m_id.size()); }
  std::int64_t operator[](Index i) const { return m_id[static_cast<std::size_t>(i)]; }
  const std::vector<std::int64_t>& ids() const { return m_id; }
  std::int64_t n_whole() const { return m_n_whole; }
  /// Every particle of the whole model is here.
  bool holds_every_particle() const { return static_cast<std::int64_t>(m_id.size()) == m_n_whole; }
  /// The particle numbered g in the whole model, or -1 when this model does not hold it.
  Index local_of(std::int64_t g) const;
  std::size_t memory_bytes() const;

 private:
  std::vector<std::int64_t> m_id;
  std::int64_t m_n_whole = 0;
  bool m_identity = true;
  std::vector<std::pair<std::int64_t, Index>> m_by_id;  ///< (global id, particle), sorted; a part's only
};

}  // namespace peristat
