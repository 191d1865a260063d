#include "support/owners.hpp"

#include <algorithm>

namespace peristat::test {

std::vector<int> x_cut_owners(const Model& model, int ranks) {
  const Constraints& cons = model.constraints;
  std::vector<Index> nodes;
  for (Index p = 0; p < model.particles.size(); ++p)
    if (cons.free_index[2 * p] >= 0 || cons.free_index[2 * p + 1] >= 0) nodes.push_back(p);
  std::stable_sort(nodes.begin(), nodes.end(), [&](Index a, Index b) {
    return model.particles.position[a].x() < model.particles.position[b].x();
  });
  std::vector<int> owner(static_cast<std::size_t>(model.particles.size()), -1);
  for (std::size_t k = 0; k < nodes.size(); ++k)
    owner[static_cast<std::size_t>(nodes[k])] =
        static_cast<int>(k * static_cast<std::size_t>(ranks) / nodes.size());
  return owner;
}

}  // namespace peristat::test
