// The exchanges between the ranks that a problem's evaluations need, built from the data of
// its options (the rows, the global ids) on its Ranks: the ghost tail of a state on a rank's
// part, and one value per particle (the damage, the pieces of the bond graph) with failure.
// Owned and counted here; none in one process.
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include "assembly/pattern.hpp"
#include "discretisation/model.hpp"
#include "parallel/exchange.hpp"
#include "parallel/ranks.hpp"

namespace peristat {

/// Per unknown of `constraints` (in the order of its free_index), the owner of its particle
/// (particle_owner), -1 for none.
std::vector<int> unknown_owners(const Constraints& constraints, const std::vector<int>& particle_owner);

/// Where this process's model sits among the ranks', as the problem's options give it.
struct RankLayout {
  const OwnedRows& rows;                             ///< the rows this process assembles
  Index owned_unknowns;                              ///< on a part: its own unknowns (the first); -1 otherwise
  const std::vector<std::int64_t>& global_id;        ///< on a part: per particle, its whole model's index
  const std::vector<std::int64_t>& global_unknown;   ///< on a part: per unknown, its whole model's index
};

class RankExchanges {
 public:
  /// Collective when any exchange is built (every rank builds its own at the same point).
  RankExchanges(const Model& model, const RankLayout& layout, bool failure, const Ranks& ranks);

  /// On a rank's part: the ghost tail of a vector over the unknowns from the owners.
  ValueExchange* ghosts() const { return m_ghosts.get(); }
  /// With failure on a part: one value per particle from its owner to the ranks that hold it;
  /// the particles without a row keep their values.
  ValueExchange* particle_values() const { return m_particle_values.get(); }
  std::size_t memory_bytes() const;

 private:
  std::unique_ptr<ValueExchange> m_ghosts, m_particle_values;
};

}  // namespace peristat
