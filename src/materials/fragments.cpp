#include "materials/fragments.hpp"

#include <algorithm>
#include <numeric>

namespace peristat {

namespace {

/// find_unsupported() on a rank's part, from the rank's pieces (`parent`, joined over the
/// intact bonds of the families it joins). A piece is labelled by the global id of its root,
/// a particle of it, so two pieces with one label share a particle and are one component. The
/// pieces of the ranks are linked through the particles they share: a particle another rank
/// owns links its piece here to its owner's (whose label the exchange brings), a particle
/// without an owner (held alike by every rank) to the node of its own global id. Every rank
/// gathers the links and the labels of its supported pieces, O(the ring) per rank, and joins
/// them alike.
template <class Root>
void find_unsupported_on_part(const Model& model, std::vector<Index>& parent, Root& root,
                              const GraphParts& parts, std::vector<char>& unsupported) {
  const Index n = model.particles.size();
  const auto gid = [&](Index i) { return parts.global_id[static_cast<std::size_t>(i)]; };
  std::vector<Index> size(static_cast<std::size_t>(n), 0);
  for (Index i = 0; i < n; ++i) ++size[root(i)];
  VectorXd label(n), theirs(n);
  for (Index i = 0; i < n; ++i) label[i] = static_cast<double>(gid(root(i)));
  theirs = label;
  parts.share(theirs);  // the particles another rank owns: the label of their owner's piece
  std::vector<std::pair<double, double>> links;
  std::vector<double> supported;
  const std::vector<Index>& free = model.constraints.free_index;
  for (Index i = 0; i < n; ++i) {
    const bool alone = size[root(i)] == 1;
    if (parts.families[static_cast<std::size_t>(i)]) {  // counted here
      if (free[2 * i] < 0 || free[2 * i + 1] < 0) supported.push_back(label[i]);
      if (parts.owner[static_cast<std::size_t>(i)] < 0 && !alone)
        links.emplace_back(label[i], static_cast<double>(gid(i)));
    } else if (!alone) {
      const double other =
          parts.owner[static_cast<std::size_t>(i)] >= 0 ? theirs[i] : static_cast<double>(gid(i));
      if (other != label[i]) links.emplace_back(label[i], other);
    }
  }
  std::sort(links.begin(), links.end());
  links.erase(std::unique(links.begin(), links.end()), links.end());
  std::sort(supported.begin(), supported.end());
  supported.erase(std::unique(supported.begin(), supported.end()), supported.end());
  std::vector<double> mine = {static_cast<double>(links.size())};
  for (const auto& [a, b] : links) mine.insert(mine.end(), {a, b});
  mine.insert(mine.end(), supported.begin(), supported.end());
  // Every rank's links and supported labels, as (count, links, labels) one rank after another:
  // the sizes tell where a rank's labels end.
  const std::vector<double> sizes = parts.gather({static_cast<double>(mine.size())});
  const std::vector<double> all = parts.gather(mine);
  // A union-find over the labels met, the same on every rank.
  std::vector<double> nodes;
  for (std::size_t r = 0, at = 0; r < sizes.size(); at += static_cast<std::size_t>(sizes[r]), ++r)
    nodes.insert(nodes.end(), all.begin() + static_cast<std::ptrdiff_t>(at + 1),
                 all.begin() + static_cast<std::ptrdiff_t>(at + static_cast<std::size_t>(sizes[r])));
  std::sort(nodes.begin(), nodes.end());
  nodes.erase(std::unique(nodes.begin(), nodes.end()), nodes.end());
  const auto node = [&](double l) {
    const auto it = std::lower_bound(nodes.begin(), nodes.end(), l);
    return it != nodes.end() && *it == l ? static_cast<Index>(it - nodes.begin()) : Index{-1};
  };
  std::vector<Index> up(nodes.size());
  std::iota(up.begin(), up.end(), Index{0});
  const auto top = [&](Index k) {
    while (up[k] != k) k = up[k] = up[up[k]];
    return k;
  };
  std::vector<char> held_up(nodes.size(), 0);
  for (std::size_t r = 0, at = 0; r < sizes.size(); at += static_cast<std::size_t>(sizes[r]), ++r) {
    const auto n_links = static_cast<std::size_t>(all[at]);
    for (std::size_t k = 0; k < n_links; ++k) {
      const Index a = top(node(all[at + 1 + 2 * k])), b = top(node(all[at + 2 + 2 * k]));
      if (a != b) up[std::max(a, b)] = std::min(a, b);  // the smaller label's node stays the root
    }
    for (std::size_t k = at + 1 + 2 * n_links; k < at + static_cast<std::size_t>(sizes[r]); ++k)
      held_up[static_cast<std::size_t>(node(all[k]))] = 1;
  }
  std::vector<char> supported_root(nodes.size(), 0);
  for (std::size_t k = 0; k < nodes.size(); ++k)
    if (held_up[k]) supported_root[static_cast<std::size_t>(top(static_cast<Index>(k)))] = 1;
  // Each particle: the label of its piece here, or of its owner's piece; then the component's.
  unsupported.assign(static_cast<std::size_t>(n), 0);
  std::vector<Index> component(static_cast<std::size_t>(n));
  for (Index i = 0; i < n; ++i) {
    const bool counted =
        parts.families[static_cast<std::size_t>(i)] || parts.owner[static_cast<std::size_t>(i)] < 0;
    const double l = counted ? label[i] : theirs[i];
    const Index k = node(l);
    if (k < 0) {  // a piece linked to no other and holding no support
      unsupported[i] = 1;
      component[i] = static_cast<Index>(l);
      continue;
    }
    const Index t = top(k);
    unsupported[i] = !supported_root[static_cast<std::size_t>(t)];
    component[i] = static_cast<Index>(nodes[static_cast<std::size_t>(t)]);
  }
  parent.swap(component);
}

}  // namespace

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
  if (parts && !parts->global_id.empty()) {
    find_unsupported_on_part(model, parent, root, *parts, unsupported);
    return;
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
