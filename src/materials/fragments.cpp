#include "materials/fragments.hpp"

#include <numeric>

namespace peristat {

void find_unsupported(const Model& model, std::span<const double> intact, std::vector<char>& unsupported,
                      std::vector<Index>& component, const GraphParts* parts) {
  const Index n = model.particles.size();
  const Bonds& bonds = model.bonds;
  // Union-find with path halving over the intact bonds.
  std::vector<Index>& parent = component;
  parent.resize(static_cast<std::size_t>(n));
  std::iota(parent.begin(), parent.end(), Index{0});
  const auto root = [&](Index i) {
    while (parent[i] != i) i = parent[i] = parent[parent[i]];
    return i;
  };
  const auto join = [&](Index i, Index j) {
    const Index a = root(i), c = root(j);
    if (a != c) parent[a] = c;
  };
  for (Index i = 0; i < n; ++i) {
    if (parts && !parts->families[static_cast<std::size_t>(i)]) continue;
    for (Index b = bonds.start[i]; b < bonds.start[i + 1]; ++b) {
      const Index j = bonds.neighbour[b];
      if (j < i || intact[b] == 0.0) continue;
      join(i, j);
    }
  }
  if (parts) {
    // This rank's components as (particle, its representative) links; every rank joins
    // every rank's links in the same order, so the components (the union of the pieces, each
    // intact pair being in one rank's piece) are the same on every rank.
    std::vector<double> links;
    for (Index i = 0; i < n; ++i)
      if (const Index r = root(i); r != i)
        links.insert(links.end(), {static_cast<double>(i), static_cast<double>(r)});
    const std::vector<double> all = parts->gather(links);
    std::iota(parent.begin(), parent.end(), Index{0});
    for (std::size_t k = 0; k < all.size(); k += 2)
      join(static_cast<Index>(all[k]), static_cast<Index>(all[k + 1]));
  }
  std::vector<char> supported(static_cast<std::size_t>(n), 0);
  const std::vector<Index>& free = model.constraints.free_index;
  for (Index i = 0; i < n; ++i)
    if (free[2 * i] < 0 || free[2 * i + 1] < 0) supported[root(i)] = 1;
  unsupported.assign(static_cast<std::size_t>(n), 0);
  for (Index i = 0; i < n; ++i) unsupported[i] = !supported[root(i)];
  for (Index i = 0; i < n; ++i) parent[i] = root(i);
}

}  // namespace peristat
