#include "discretisation/model_part.hpp"

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
  b.xi.reserve(n_part_bonds);
  b.weight.reserve(n_part_bonds);
  std::vector<Index> bond_of(static_cast<std::size_t>(wb.n_bonds()), -1);  // whole bond -> part bond
  for (Index l = 0; l < nl; ++l) {
    const Index g = order[l];
    if (held[static_cast<std::size_t>(g)]) {
      m.family_held[static_cast<std::size_t>(l)] = 1;
      for (Index wbnd = wb.start[g]; wbnd < wb.start[g + 1]; ++wbnd) {
        const Index j = local[static_cast<std::size_t>(wb.neighbour[wbnd])];
        if (j < 0) throw std::logic_error("extract_part: a held family's neighbour is not kept");
        bond_of[static_cast<std::size_t>(wbnd)] = b.n_bonds();
        b.neighbour.push_back(j);
        b.xi.push_back(wb.xi[wbnd]);
        b.weight.push_back(wb.weight[wbnd]);
      }
    }
    b.start[static_cast<std::size_t>(l) + 1] = b.n_bonds();
  }
  // The whole model's index of each held family's first bond: a broken bond's identity
  // across the ranks and in a checkpoint (bond k of the family is whole_start[l] + k).
  m.whole_start.assign(static_cast<std::size_t>(nl) + 1, m.n_bonds_whole);
  for (Index l = 0; l < nl; ++l) {
    const Index g = order[l];
    m.whole_start[static_cast<std::size_t>(l)] =
        whole.holds_every_family() ? wb.start[g] : whole.whole_start[static_cast<std::size_t>(g)];
  }
  b.reverse.assign(b.neighbour.size(), -1);
  for (std::size_t wbnd = 0; wbnd < bond_of.size(); ++wbnd)
    if (const Index pb = bond_of[wbnd]; pb >= 0)
      if (const Index wr = wb.reverse[wbnd]; wr >= 0)
        b.reverse[static_cast<std::size_t>(pb)] = bond_of[static_cast<std::size_t>(wr)];
}

}  // namespace

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
