#include "discretisation/model_part.hpp"

#include "discretisation/model_builder.hpp"

#include <algorithm>
#include <numeric>
#include <limits>
#include <stdexcept>
#include <string>

namespace peristat {

namespace {

template <class T>
std::vector<T> permuted(const std::vector<T>& values, const std::vector<Index>& order) {
  std::vector<T> out;
  out.reserve(order.size());
  for (const Index g : order) out.push_back(values[static_cast<std::size_t>(g)]);
  return out;
}

/// The lattice index of the part's particles: the box of their lattice points.
LatticeIndex part_lattice_index(const Particles& p) {
  if (p.size() == 0) return {};
  int i0 = std::numeric_limits<int>::max(), j0 = i0, i1 = std::numeric_limits<int>::min(), j1 = i1;
  for (const auto& l : p.lattice) {
    i0 = std::min(i0, l[0]);
    j0 = std::min(j0, l[1]);
    i1 = std::max(i1, l[0]);
    j1 = std::max(j1, l[1]);
  }
  LatticeIndex index(i0, j0, i1, j1);
  for (Index q = 0; q < p.size(); ++q) index.set(p.lattice[q][0], p.lattice[q][1], q);
  return index;
}

/// Checks the owner and held tables against `whole`: one entry per particle, every particle
/// `rank` owns held, every held family held by `whole`. Throws std::logic_error otherwise.
void check_part_tables(const Model& whole, const std::vector<int>& owner, int rank,
                       const std::vector<char>& held) {
  const Index n = whole.particles.size();
  if (owner.size() != static_cast<std::size_t>(n) || held.size() != static_cast<std::size_t>(n))
    throw std::logic_error("extract_part: the owner and held tables must have one entry per particle");
  for (Index g = 0; g < n; ++g) {
    const auto gs = static_cast<std::size_t>(g);
    if (owner[gs] == rank && !held[gs])
      throw std::logic_error("extract_part: rank " + std::to_string(rank) + " owns particle " +
                             std::to_string(g) + " and does not hold its family");
    if (held[gs] && !whole.holds_every_family() && !whole.family_held[gs])
      throw std::logic_error("extract_part: the family of particle " + std::to_string(g) +
                             " is to be held and the whole model does not hold it");
  }
}

/// Per particle of `whole`: whether the part keeps it.
std::vector<char> kept_particles(const Model& whole, const std::vector<char>& held,
                                 const std::vector<std::int64_t>& extra) {
  const Index n = whole.particles.size();
  // The particles kept: the held ones and their neighbours, the extra ones, and the sources of the mirror
  // ghosts among them (a ghost's displacement is its source's image; a source is never a ghost).
  std::vector<char> kept = within_stencil(whole, held);
  for (const std::int64_t g : extra) {
    if (g < 0 || g >= n) throw std::logic_error("extract_part: an extra particle is not in the model");
    kept[static_cast<std::size_t>(g)] = 1;
  }
  for (const MirrorImage& im : whole.constraints.images)
    if (kept[static_cast<std::size_t>(im.ghost)]) kept[static_cast<std::size_t>(im.source)] = 1;
  return kept;
}

/// The part's order (part -> whole): the particles `rank` owns, then the other kept ones.
std::vector<Index> part_order(const std::vector<int>& owner, int rank, const std::vector<char>& kept) {
  const auto n = static_cast<Index>(owner.size());
  std::vector<Index> order;  // part -> whole
  for (Index g = 0; g < n; ++g)
    if (owner[static_cast<std::size_t>(g)] == rank) order.push_back(g);
  for (Index g = 0; g < n; ++g)
    if (kept[static_cast<std::size_t>(g)] && owner[static_cast<std::size_t>(g)] != rank) order.push_back(g);
  return order;
}

/// Copies the model-wide fields and the kept particles, in the part's order, into `m`.
void copy_particles(const Model& whole, const std::vector<Index>& order, Model& m) {
  m.stencil = whole.stencil;
  m.spacing = whole.spacing;
  m.horizon = whole.horizon;
  m.n_cut_bonds = whole.n_cut_bonds;
  m.bodies = whole.bodies;
  m.cracks = whole.cracks;
  m.n_bonds_whole = whole.holds_every_family() ? whole.bonds.n_bonds() : whole.n_bonds_whole;

  const Particles& wp = whole.particles;
  m.particles.position = permuted(wp.position, order);
  m.particles.volume = permuted(wp.volume, order);
  m.particles.body = permuted(wp.body, order);
  m.particles.fictitious = permuted(wp.fictitious, order);
  m.particles.lattice = permuted(wp.lattice, order);
  m.lattice_index = part_lattice_index(m.particles);
}

/// Fills the part's constraints and its map of unknowns to the whole's.
void part_constraints(const Constraints& wc, const std::vector<Index>& order,
                      const std::vector<Index>& local, ModelPart& part) {
  const auto nl = static_cast<Index>(order.size());
  const Index n_owned = part.n_owned;
  // Constraints: the components of the kept particles; unknowns numbered in the part's order.
  Constraints& c = part.model.constraints;
  c.prescribed.resize(2 * order.size());
  c.value.resize(2 * order.size());
  c.free_index.assign(2 * order.size(), -1);
  for (Index l = 0; l < nl; ++l)
    for (int k = 0; k < 2; ++k) {
      const std::size_t d = 2 * static_cast<std::size_t>(l) + k,
                        wd = 2 * static_cast<std::size_t>(order[l]) + k;
      c.prescribed[d] = wc.prescribed[wd];
      c.value[d] = wc.value[wd];
      if (wc.free_index[wd] < 0) continue;
      c.free_index[d] = c.n_free++;
      part.global_unknown.push_back(wc.free_index[wd]);
      if (l < n_owned) part.n_owned_unknowns = c.n_free;
    }
  c.condition_dofs.resize(wc.condition_dofs.size());
  for (std::size_t k = 0; k < wc.condition_dofs.size(); ++k) {
    for (const Index wd : wc.condition_dofs[k])
      if (const Index l = local[static_cast<std::size_t>(wd / 2)]; l >= 0)
        c.condition_dofs[k].push_back(2 * l + wd % 2);
    std::sort(c.condition_dofs[k].begin(), c.condition_dofs[k].end());
  }
  for (const MirrorImage& im : wc.images)
    if (const Index l = local[static_cast<std::size_t>(im.ghost)]; l >= 0)
      c.images.push_back({l, local[static_cast<std::size_t>(im.source)], im.sign});
  if (!c.images.empty()) {
    std::stable_sort(c.images.begin(), c.images.end(),
                     [](const MirrorImage& a, const MirrorImage& b) { return a.source < b.source; });
    c.image_start.assign(static_cast<std::size_t>(nl) + 1, 0);
    for (const MirrorImage& im : c.images) ++c.image_start[static_cast<std::size_t>(im.source) + 1];
    for (Index l = 0; l < nl; ++l) c.image_start[l + 1] += c.image_start[l];
  }
}

/// Fills the part's bonds, family_held and whole_start from the held families of `whole`.
void part_bonds(const Model& whole, const std::vector<Index>& order, const std::vector<Index>& local,
                const std::vector<char>& held, Model& m) {
  const auto nl = static_cast<Index>(order.size());
  // Bonds: the held families, in the part's order; a bond's reverse where its neighbour's
  // family is held too.
  const Bonds& wb = whole.bonds;
  Bonds& b = m.bonds;
  m.family_held.assign(static_cast<std::size_t>(nl), 0);
  b.start.assign(static_cast<std::size_t>(nl) + 1, 0);
  std::size_t n_part_bonds = 0;  // exact capacities: the bonds are most of a part's bytes
  for (const Index g : order)
    if (held[static_cast<std::size_t>(g)]) n_part_bonds += static_cast<std::size_t>(wb.family_size(g));
  b.neighbour.reserve(n_part_bonds);
  b.stencil_weight = wb.stencil_weight;
  b.own_start.assign(1, 0);
  b.own_start.reserve(static_cast<std::size_t>(nl) + 1);
  std::vector<Index> bond_of(static_cast<std::size_t>(wb.n_bonds()), -1);  // whole bond -> part bond
  for (Index l = 0; l < nl; ++l) {
    const Index g = order[l];
    std::span<const double> w;
    if (held[static_cast<std::size_t>(g)]) {
      m.family_held[static_cast<std::size_t>(l)] = 1;
      w = wb.weights(g);
      for (Index wbnd = wb.start[g]; wbnd < wb.start[g + 1]; ++wbnd) {
        const Index j = local[static_cast<std::size_t>(wb.neighbour[wbnd])];
        if (j < 0) throw std::logic_error("extract_part: a held family's neighbour is not kept");
        bond_of[static_cast<std::size_t>(wbnd)] = b.n_bonds();
        b.neighbour.push_back(j);
      }
    }
    b.start[static_cast<std::size_t>(l) + 1] = b.n_bonds();
    b.add_weights(w);
  }
  // The whole model's index of each held family's first bond: a broken bond's identity
  // across the ranks and in a checkpoint (bond k of the family is whole_start[l] + k).
  m.whole_start.assign(static_cast<std::size_t>(nl) + 1, m.n_bonds_whole);
  for (Index l = 0; l < nl; ++l) {
    const Index g = order[l];
    m.whole_start[static_cast<std::size_t>(l)] =
        whole.holds_every_family() ? wb.start[g] : whole.whole_start[static_cast<std::size_t>(g)];
  }
  std::vector<Index> reverse(b.neighbour.size(), -1);
  for (Index g = 0; g < whole.particles.size(); ++g)
    for (Index wbnd = wb.start[g]; wbnd < wb.start[g + 1]; ++wbnd)
      if (const Index pb = bond_of[static_cast<std::size_t>(wbnd)]; pb >= 0)
        if (const Index wr = wb.reverse(g, wbnd); wr >= 0)
          reverse[static_cast<std::size_t>(pb)] = bond_of[static_cast<std::size_t>(wr)];
  b.stencil_mirror = wb.stencil_mirror;
  b.set_reverse(reverse);
}


/// The points of a part: those of the window around the rank's region that the rank owns,
/// holds or keeps, as flags over the window (docs/guide/distributed.md, "The partitioned model").
class PartWindow {
 public:
  PartWindow(const LatticeCensus& census, const LatticePartition& partition, int rank, int rings, int margin)
      : m_census(census) {
    const LatticeBox& region = partition.region(rank);
    m_box.lo = {std::max(region.lo[0] - margin, census.i0), std::max(region.lo[1] - margin, census.j0)};
    m_box.hi = {std::min(region.hi[0] + margin, census.i0 + census.ni - 1),
                std::min(region.hi[1] + margin, census.j0 + census.nj - 1)};
    m_nj = m_box.hi[1] - m_box.lo[1] + 1;
    const std::size_t size = static_cast<std::size_t>(m_box.hi[0] - m_box.lo[0] + 1) * static_cast<std::size_t>(m_nj);
    m_owned.assign(size, 0);
    for (int i = m_box.lo[0]; i <= m_box.hi[0]; ++i)
      for (int j = m_box.lo[1]; j <= m_box.hi[1]; ++j)
        if (census.at(i, j).exists() && partition.owner(i, j) == rank) m_owned[index(i, j)] = 1;
    m_held = m_owned;
    for (int ring = 0; ring < rings; ++ring) m_held = widened(m_held);
    m_kept = widened(m_held);
    // The sources of the ghosts kept (a ghost's displacement is its source's image).
    std::array<int, 2> s{};
    for (int i = m_box.lo[0]; i <= m_box.hi[0]; ++i)
      for (int j = m_box.lo[1]; j <= m_box.hi[1]; ++j)
        if (m_kept[index(i, j)] && census.source_of(i, j, s)) m_kept[checked(s[0], s[1])] = 1;
  }

  bool contains(int i, int j) const { return m_box.contains(i, j); }
  bool owned(int i, int j) const { return contains(i, j) && m_owned[index(i, j)]; }
  bool held(int i, int j) const { return contains(i, j) && m_held[index(i, j)]; }
  bool kept(int i, int j) const { return contains(i, j) && m_kept[index(i, j)]; }

 private:
  const LatticeCensus& m_census;
  LatticeBox m_box;
  int m_nj = 0;
  std::vector<char> m_owned, m_held, m_kept;

  std::size_t index(int i, int j) const {
    return static_cast<std::size_t>(i - m_box.lo[0]) * static_cast<std::size_t>(m_nj) +
           static_cast<std::size_t>(j - m_box.lo[1]);
  }
  std::size_t checked(int i, int j) const {
    if (!contains(i, j)) throw std::logic_error("build_part: the window misses a particle the part keeps");
    return index(i, j);
  }
  /// The flagged points and every particle within the stencil of one (within_stencil()'s).
  std::vector<char> widened(const std::vector<char>& seeds) const {
    std::vector<char> near = seeds;
    for (int i = m_box.lo[0]; i <= m_box.hi[0]; ++i)
      for (int j = m_box.lo[1]; j <= m_box.hi[1]; ++j) {
        if (!seeds[index(i, j)]) continue;
        for (const auto& o : m_census.stencil.offset)
          if (m_census.at(i + o[0], j + o[1]).exists()) near[checked(i + o[0], j + o[1])] = 1;
      }
    return near;
  }
};

/// The lattice points (census linear indices, sorted) of the `extra` particles and of the
/// sources of the ghosts among them.
std::vector<std::size_t> extra_points(const LatticeCensus& census, std::vector<std::int64_t> extra) {
  std::vector<std::size_t> points;
  if (extra.empty()) return points;
  std::sort(extra.begin(), extra.end());
  extra.erase(std::unique(extra.begin(), extra.end()), extra.end());
  const std::vector<KeptPoint> found = number_points(census, [&](int, int, std::int64_t id) {
    return std::binary_search(extra.begin(), extra.end(), id);
  });
  if (found.size() != extra.size()) throw std::logic_error("build_part: an extra particle is not in the model");
  std::array<int, 2> s{};
  for (const KeptPoint& k : found) {
    points.push_back(census.linear(k.i, k.j));
    if (census.source_of(k.i, k.j, s)) points.push_back(census.linear(s[0], s[1]));
  }
  std::sort(points.begin(), points.end());
  points.erase(std::unique(points.begin(), points.end()), points.end());
  return points;
}

}  // namespace

ModelPart build_part(const ModelDescription& scene, const LatticeCensus& census, const LatticePartition& partition,
                     int rank, int rings, const std::vector<std::int64_t>& extra) {
  // The window's margin around the region: an owned ghost's source lies within 2 mirror
  // depths of it, the held families `rings` stencils further, their neighbours one more,
  // the sources of the ghosts among those 2 mirror depths more.
  const int reach = census.stencil.reach;
  const int mirror = mirror_layers(scene.discretization.horizon_factor);
  const PartWindow window(census, partition, rank, rings, 4 * mirror + (rings + 1) * reach + 1);
  const std::vector<std::size_t> outside = extra_points(census, extra);
  std::vector<KeptPoint> kept = number_points(census, [&](int i, int j, std::int64_t) {
    return window.kept(i, j) || std::binary_search(outside.begin(), outside.end(), census.linear(i, j));
  });
  for (KeptPoint& k : kept) {
    k.owned = window.owned(k.i, k.j);
    k.held = window.held(k.i, k.j);
  }
  // The part's order: the owned particles, then the others, each by number.
  std::sort(kept.begin(), kept.end(), [](const KeptPoint& a, const KeptPoint& b) {
    return a.owned != b.owned ? a.owned : a.id < b.id;
  });
  ModelPart part;
  part.model = model_of(scene, census, kept, false, &part.global_unknown);
  part.n_owned = static_cast<Index>(std::count_if(kept.begin(), kept.end(), [](const KeptPoint& k) { return k.owned; }));
  const std::vector<Index>& free = part.model.constraints.free_index;
  for (Index l = 0; l < part.n_owned; ++l)
    part.n_owned_unknowns += (free[2 * static_cast<std::size_t>(l)] >= 0) + (free[2 * static_cast<std::size_t>(l) + 1] >= 0);
  part.n_particles_whole = census.n_particles();
  part.n_unknowns_whole = census.n_unknowns();
  part.global_id.reserve(kept.size());
  part.owner.reserve(kept.size());
  for (const KeptPoint& k : kept) {
    part.global_id.push_back(k.id);
    part.owner.push_back(partition.owner(k.i, k.j));
  }
  return part;
}

std::size_t ModelPart::memory_bytes() const {
  auto bytes = [](const auto& v) { return v.capacity() * sizeof(v[0]); };
  return model.memory_bytes() + bytes(global_id) + bytes(owner) + bytes(global_unknown);
}

ModelPart extract_part(const Model& whole, const std::vector<int>& owner, int rank,
                       const std::vector<char>& held, const std::vector<std::int64_t>& extra) {
  check_part_tables(whole, owner, rank, held);
  const Index n = whole.particles.size();
  const std::vector<char> kept = kept_particles(whole, held, extra);
  const std::vector<Index> order = part_order(owner, rank, kept);  // part -> whole
  std::vector<Index> local(static_cast<std::size_t>(n), -1);        // whole -> part
  for (std::size_t l = 0; l < order.size(); ++l)
    local[static_cast<std::size_t>(order[l])] = static_cast<Index>(l);

  ModelPart part;
  part.n_owned = static_cast<Index>(std::count_if(
      owner.begin(), owner.end(), [rank](int o) { return o == rank; }));
  part.n_particles_whole = n;
  part.n_unknowns_whole = whole.constraints.n_free;
  part.global_id.assign(order.begin(), order.end());
  part.owner = permuted(owner, order);
  copy_particles(whole, order, part.model);
  part_constraints(whole.constraints, order, local, part);
  part_bonds(whole, order, local, held, part.model);
  return part;
}

ModelPart whole_as_part(Model&& whole) {
  if (!whole.holds_every_family()) throw std::logic_error("whole_as_part: a model holding every family");
  const Index n = whole.particles.size(), n_free = whole.constraints.n_free;
  ModelPart part;
  part.n_owned = n;
  part.n_owned_unknowns = n_free;
  part.n_particles_whole = n;
  part.n_unknowns_whole = n_free;
  part.global_id.resize(static_cast<std::size_t>(n));
  std::iota(part.global_id.begin(), part.global_id.end(), std::int64_t{0});
  part.owner.assign(static_cast<std::size_t>(n), 0);
  part.global_unknown.resize(static_cast<std::size_t>(n_free));
  std::iota(part.global_unknown.begin(), part.global_unknown.end(), std::int64_t{0});
  // As extract_part() leaves a part holding every family: each held, each family's first bond
  // its own index.
  whole.family_held.assign(static_cast<std::size_t>(n), 1);
  whole.whole_start.assign(whole.bonds.start.begin(), whole.bonds.start.end());
  part.model = std::move(whole);
  return part;
}

}  // namespace peristat
