#include "discretisation/lattice_partition.hpp"

#include <cstdint>
#include <cstdlib>
#include <stdexcept>

namespace peristat {

LatticePartition::LatticePartition(const LatticeCensus& census, int parts, BelosPartition kind)
    : m_census(census), m_region(static_cast<std::size_t>(std::max(parts, 1))) {
  if (parts < 1) throw std::logic_error("LatticePartition: at least one part");
  LatticeBox box;
  box.lo = {census.i0, census.j0};
  box.hi = {census.i0 + census.ni - 1, census.j0 + census.nj - 1};
  bisect(box, 0, parts, kind);
}

int LatticePartition::bisect(const LatticeBox& box, int first_part, int n_parts, BelosPartition kind) {
  const int self = static_cast<int>(m_tree.size());
  m_tree.emplace_back();
  if (n_parts == 1) {
    m_tree[static_cast<std::size_t>(self)].part = first_part;
    m_region[static_cast<std::size_t>(first_part)] = box;
    return self;
  }
  // The nodes' extent in the box, and their count per line across each axis.
  std::array<std::vector<std::int64_t>, 2> per_line;
  for (int a = 0; a < 2; ++a) per_line[static_cast<std::size_t>(a)].assign(static_cast<std::size_t>(box.hi[a] - box.lo[a] + 1), 0);
  std::int64_t nodes = 0;
  std::array<int, 2> lo = box.hi, hi = box.lo;
  for (int i = box.lo[0]; i <= box.hi[0]; ++i)
    for (int j = box.lo[1]; j <= box.hi[1]; ++j) {
      if (!m_census.point[m_census.linear(i, j)].node()) continue;
      ++nodes;
      ++per_line[0][static_cast<std::size_t>(i - box.lo[0])];
      ++per_line[1][static_cast<std::size_t>(j - box.lo[1])];
      lo = {std::min(lo[0], i), std::min(lo[1], j)};
      hi = {std::max(hi[0], i), std::max(hi[1], j)};
    }
  int axis = 0;
  if (kind == BelosPartition::rcb && nodes > 0 && hi[1] - lo[1] > hi[0] - lo[0]) axis = 1;
  const auto a = static_cast<std::size_t>(axis);
  // Cut after the line where the running count comes nearest the left parts' share.
  const int n_left = n_parts / 2;
  const double target = static_cast<double>(nodes) * n_left / n_parts;
  int at = box.lo[axis] + (box.hi[axis] - box.lo[axis]) / 2;  // no nodes: the middle
  if (nodes > 0) {
    double best = -1.0;
    std::int64_t running = 0;
    for (int line = box.lo[axis]; line < box.hi[axis]; ++line) {
      running += per_line[a][static_cast<std::size_t>(line - box.lo[axis])];
      const double miss = std::abs(static_cast<double>(running) - target);
      if (best < 0.0 || miss < best) {
        best = miss;
        at = line;
      }
    }
  }
  LatticeBox left = box, right = box;
  left.hi[a] = at;
  right.lo[a] = at + 1;
  if (right.lo[a] > right.hi[a]) throw std::logic_error("LatticePartition: a box too thin to cut");
  const int l = bisect(left, first_part, n_left, kind);
  const int r = bisect(right, first_part + n_left, n_parts - n_left, kind);
  Cut& cut = m_tree[static_cast<std::size_t>(self)];
  cut.axis = axis;
  cut.at = at;
  cut.left = l;
  cut.right = r;
  return self;
}

int LatticePartition::region_at(int i, int j) const {
  const std::array<int, 2> x{i, j};
  std::size_t node = 0;
  while (m_tree[node].axis >= 0) {
    const Cut& c = m_tree[node];
    node = static_cast<std::size_t>(x[static_cast<std::size_t>(c.axis)] <= c.at ? c.left : c.right);
  }
  return m_tree[node].part;
}

int LatticePartition::owner(int i, int j) const {
  std::array<int, 2> source{};
  if (m_census.source_of(i, j, source)) return region_at(source[0], source[1]);
  return region_at(i, j);
}

}  // namespace peristat
