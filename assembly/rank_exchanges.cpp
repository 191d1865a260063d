#include "assembly/rank_exchanges.hpp"

#include <algorithm>
#include <stdexcept>

namespace peristat {

std::vector<int> unknown_owners(const Constraints& constraints, const std::vector<int>& particle_owner) {
  std::vector<int> owner(static_cast<std::size_t>(constraints.n_free), -1);
  const std::vector<Index>& free = constraints.free_index;
  for (std::size_t c = 0; c < free.size(); ++c)
    if (free[c] >= 0) owner[static_cast<std::size_t>(free[c])] = particle_owner[c / 2];
  return owner;
}

RankExchanges::RankExchanges(const Model& model, const RankLayout& layout, bool failure, const Ranks& ranks) {
  const std::vector<int>& owner = layout.rows.owner;
  const bool part = !layout.global_id.empty();  // the model is a rank's part, numbered by global ids
  if (layout.owned_unknowns >= 0)
    m_ghosts = std::make_unique<PartExchange>(ranks, layout.global_unknown,
                                              unknown_owners(model.constraints, owner),
                                              static_cast<std::size_t>(layout.owned_unknowns));
  if (model.holds_every_family() || !failure) return;
  if (!part) throw std::logic_error("RankExchanges: a model holding some families only must be a rank's part");
  // A part's own particles come first.
  const auto n_owned = static_cast<std::size_t>(std::count(owner.begin(), owner.end(), layout.rows.rank));
  m_particle_values = std::make_unique<OwnedEntriesExchange>(ranks, layout.global_id, owner, n_owned);
}

std::size_t RankExchanges::memory_bytes() const {
  std::size_t bytes = 0;
  for (const auto* e : {m_ghosts.get(), m_particle_values.get()})
    if (e) bytes += e->memory_bytes();
  return bytes;
}

}  // namespace peristat
