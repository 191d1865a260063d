#include "support/owners.hpp"

#include <algorithm>
#include <cstdint>

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

std::vector<int> strip_owners(const Constraints& cons, int ranks) {
  const Index n = static_cast<Index>(cons.free_index.size() / 2);
  const auto is_node = [&](Index p) { return cons.free_index[2 * p] >= 0 || cons.free_index[2 * p + 1] >= 0; };
  std::int64_t nodes = 0;
  for (Index p = 0; p < n; ++p) nodes += is_node(p);
  std::vector<int> owner(static_cast<std::size_t>(n), -1);
  std::int64_t node = 0;
  for (Index p = 0; p < n; ++p)
    if (is_node(p)) owner[static_cast<std::size_t>(p)] = static_cast<int>(node++ * ranks / nodes);
  return owner;
}

void complete_owners(const Model& model, std::vector<int>& owner) {
  const Particles& p = model.particles;
  std::vector<Index> queue;
  queue.reserve(owner.size());
  for (Index q = 0; q < p.size(); ++q)
    if (owner[static_cast<std::size_t>(q)] >= 0) queue.push_back(q);
  for (std::size_t head = 0; head < queue.size(); ++head) {
    const Index q = queue[head];
    for (const auto& o : model.stencil.offset) {
      const Index j = model.lattice_index.at(p.lattice[q][0] + o[0], p.lattice[q][1] + o[1]);
      if (j < 0 || owner[static_cast<std::size_t>(j)] >= 0) continue;
      owner[static_cast<std::size_t>(j)] = owner[static_cast<std::size_t>(q)];
      queue.push_back(j);
    }
  }
  for (int& o : owner)
    if (o < 0) o = 0;
  for (const MirrorImage& im : model.constraints.images)
    owner[static_cast<std::size_t>(im.ghost)] = owner[static_cast<std::size_t>(im.source)];
}

}  // namespace peristat::test
