#include "materials/fragments.hpp"

#include <algorithm>
#include <numeric>
#include <stdexcept>

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
  std::vector<std::int64_t> label(static_cast<std::size_t>(n)), theirs;
  for (Index i = 0; i < n; ++i) label[static_cast<std::size_t>(i)] = gid(root(i));
  theirs = label;
  parts.share->share(theirs.data());  // the particles another rank owns: the label of their owner's piece
  struct Link {
    std::int64_t a, b;
    bool operator<(const Link& o) const { return std::pair(a, b) < std::pair(o.a, o.b); }
    bool operator==(const Link& o) const { return a == o.a && b == o.b; }
  };
  std::vector<Link> links;
  std::vector<std::int64_t> supported;
  const std::vector<Index>& free = model.constraints.free_index;
  for (Index i = 0; i < n; ++i) {
    const bool alone = size[root(i)] == 1;
    const std::int64_t li = label[static_cast<std::size_t>(i)];
    if (parts.families[static_cast<std::size_t>(i)]) {  // counted here
      if (free[2 * i] < 0 || free[2 * i + 1] < 0) supported.push_back(li);
      if (parts.owner[static_cast<std::size_t>(i)] < 0 && !alone) links.push_back({li, gid(i)});
    } else if (!alone) {
      const std::int64_t other =
          parts.owner[static_cast<std::size_t>(i)] >= 0 ? theirs[static_cast<std::size_t>(i)] : gid(i);
      if (other != li) links.push_back({li, other});
    }
  }
  std::sort(links.begin(), links.end());
  links.erase(std::unique(links.begin(), links.end()), links.end());
  std::sort(supported.begin(), supported.end());
  supported.erase(std::unique(supported.begin(), supported.end()), supported.end());
  // Every rank's links and supported labels. A union-find over the labels met, the same on
  // every rank: a component's root is its smallest label whatever the order of the joins.
  const std::vector<Link> all_links = parts.ranks.all_gather(links);
  const std::vector<std::int64_t> all_supported = parts.ranks.all_gather(supported);
  std::vector<std::int64_t> nodes = all_supported;
  for (const Link& l : all_links) nodes.insert(nodes.end(), {l.a, l.b});
  std::sort(nodes.begin(), nodes.end());
  nodes.erase(std::unique(nodes.begin(), nodes.end()), nodes.end());
  const auto node = [&](std::int64_t l) {
    const auto it = std::lower_bound(nodes.begin(), nodes.end(), l);
    return it != nodes.end() && *it == l ? static_cast<Index>(it - nodes.begin()) : Index{-1};
  };
  std::vector<Index> up(nodes.size());
  std::iota(up.begin(), up.end(), Index{0});
  const auto top = [&](Index k) {
    while (up[k] != k) k = up[k] = up[up[k]];
    return k;
  };
  for (const Link& l : all_links) {
    const Index a = top(node(l.a)), b = top(node(l.b));
    if (a != b) up[std::max(a, b)] = std::min(a, b);  // the smaller label's node stays the root
  }
  std::vector<char> held_up(nodes.size(), 0);
  for (const std::int64_t l : all_supported) held_up[static_cast<std::size_t>(node(l))] = 1;
  std::vector<char> supported_root(nodes.size(), 0);
  for (std::size_t k = 0; k < nodes.size(); ++k)
    if (held_up[k]) supported_root[static_cast<std::size_t>(top(static_cast<Index>(k)))] = 1;
  // Each particle: the label of its piece here, or of its owner's piece; then the component's.
  unsupported.assign(static_cast<std::size_t>(n), 0);
  std::vector<Index> component(static_cast<std::size_t>(n));
  for (Index i = 0; i < n; ++i) {
    const bool counted =
        parts.families[static_cast<std::size_t>(i)] || parts.owner[static_cast<std::size_t>(i)] < 0;
    const std::int64_t l = counted ? label[static_cast<std::size_t>(i)] : theirs[static_cast<std::size_t>(i)];
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
  if (parts) {
    if (parts->global_id.empty()) throw std::logic_error("find_unsupported: the graph's parts need global ids");
    find_unsupported_on_part(model, parent, root, *parts, unsupported);
    return;
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
