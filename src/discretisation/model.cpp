#include "discretisation/model.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <string>

#include "core/huge_pages.hpp"
#include "core/geometry.hpp"
#include "discretisation/lattice_partition.hpp"
#include "discretisation/model_builder.hpp"

namespace peristat {

namespace {

/// Area of the unit cell centred at (ci, cj) inside the disc of radius r centred at the
/// origin (lengths in units of dx). Composite midpoint rule over x of the clipped chord;
/// 4000 panels give an error far below 1e-8 of the cell area.
double cell_area_in_disc(int ci, int cj, double r) {
  const int n = 4000;
  const double x0 = ci - 0.5, y0 = cj - 0.5, y1 = cj + 0.5;
  double area = 0.0;
  for (int k = 0; k < n; ++k) {
    const double x = x0 + (k + 0.5) / n;
    if (std::abs(x) >= r) continue;
    const double s = std::sqrt(r * r - x * x);
    area += std::max(0.0, std::min(y1, s) - std::max(y0, -s));
  }
  return area / n;
}

double cross(const Vec2& a, const Vec2& b) {
  return a.x() * b.y() - a.y() * b.x();
}

/// The steps of model_of(): particles, constraints, bonds.
class ModelMaker {
 public:
  ModelMaker(const ModelDescription& scene, const LatticeCensus& census, const std::vector<KeptPoint>& kept,
             bool whole)
      : m_scene(scene), m_census(census), m_kept(kept), m_whole(whole), m_dx(census.spacing) {}

  Model build(std::vector<std::int64_t>* global_unknown) {
    m_model.spacing = m_dx;
    m_model.horizon = m_scene.discretization.horizon_factor * m_dx;
    m_model.stencil = m_census.stencil;
    for (const Body& body : m_scene.bodies)
      m_model.bodies.push_back({body.name, m_scene.materials.at(body.material), body.shape});
    m_model.cracks = m_scene.cracks;
    add_particles();
    add_constraints(global_unknown);
    build_bonds();
    return std::move(m_model);
  }

 private:
  const ModelDescription& m_scene;
  const LatticeCensus& m_census;
  const std::vector<KeptPoint>& m_kept;
  bool m_whole;
  double m_dx;
  Model m_model;

  void add_particles() {
    Particles& p = m_model.particles;
    const std::size_t n = m_kept.size();
    p.position.reserve(n);
    p.volume.reserve(n);
    p.body.reserve(n);
    p.fictitious.reserve(n);
    p.lattice.reserve(n);
    for (const KeptPoint& k : m_kept) {
      const CensusPoint c = m_census.at(k.i, k.j);
      const int body = m_census.body(c);
      p.position.push_back(m_census.position(k.i, k.j));
      p.volume.push_back(m_dx * m_dx * m_scene.materials.at(m_scene.bodies[body].material).thickness);
      p.body.push_back(body);
      p.fictitious.push_back(m_census.fictitious(c) ? 1 : 0);
      p.lattice.push_back({k.i, k.j});
    }
    // The whole model's index spans the census box; a part's the box of its own points.
    LatticeBox box;
    if (m_whole) {
      box.lo = {m_census.i0, m_census.j0};
      box.hi = {m_census.i0 + m_census.ni - 1, m_census.j0 + m_census.nj - 1};
    } else if (n > 0) {
      box.lo = box.hi = {m_kept[0].i, m_kept[0].j};
      for (const KeptPoint& k : m_kept) {
        box.lo = {std::min(box.lo[0], k.i), std::min(box.lo[1], k.j)};
        box.hi = {std::max(box.hi[0], k.i), std::max(box.hi[1], k.j)};
      }
    }
    m_model.lattice_index = LatticeIndex(box.lo[0], box.lo[1], box.hi[0], box.hi[1]);
    for (std::size_t q = 0; q < n; ++q) m_model.lattice_index.set(m_kept[q].i, m_kept[q].j, static_cast<Index>(q));
  }

  /// The value at load factor 1 of component `comp` of the particle at `x`, which condition
  /// k prescribes: its affine value there, or a mirror ghost's 2 U(foot) (normal) and 0.
  double prescribed_value(int k, int comp, const Vec2& x) const {
    const BoundaryCondition& bc = m_scene.boundary[static_cast<std::size_t>(k)];
    const int axis = m_census.mirror_axis[static_cast<std::size_t>(k)];
    if (axis < 0) return (comp == 0 ? bc.ux : bc.uy)->at(x);
    if (comp != axis) return 0.0;
    const Polygon& shape = m_model.bodies[static_cast<std::size_t>(m_census.group_body[m_census.n_bodies + k + 1])].shape;
    Vec2 foot = x;
    foot[axis] = shape.vertices[bc.edge][axis];
    return 2.0 * (axis == 0 ? bc.ux : bc.uy)->at(foot);
  }

  void add_constraints(std::vector<std::int64_t>* global_unknown) {
    Constraints& c = m_model.constraints;
    const std::size_t n = m_kept.size();
    c.prescribed.assign(2 * n, 0);
    c.value.assign(2 * n, 0.0);
    c.free_index.assign(2 * n, -1);
    c.condition_dofs.assign(m_scene.boundary.size(), {});
    for (std::size_t l = 0; l < n; ++l) {
      const KeptPoint& k = m_kept[l];
      const CensusPoint p = m_census.at(k.i, k.j);
      std::int64_t unknown = k.first_unknown;
      for (int comp = 0; comp < 2; ++comp) {
        const std::size_t d = 2 * l + static_cast<std::size_t>(comp);
        const int by = p.prescribed_by[static_cast<std::size_t>(comp)];
        if (by == 0) {
          c.free_index[d] = c.n_free++;
          if (global_unknown) global_unknown->push_back(unknown);
          ++unknown;
          continue;
        }
        c.prescribed[d] = 1;
        c.value[d] = prescribed_value(by - 1, comp, m_model.particles.position[l]);
        c.condition_dofs[static_cast<std::size_t>(by - 1)].push_back(static_cast<Index>(d));
      }
      std::array<int, 2> source{};
      if (!m_census.source_of(k.i, k.j, source)) continue;
      const int axis = m_census.mirror_axis[static_cast<std::size_t>(p.prescribed_by[0] - 1)];
      MirrorImage image{static_cast<Index>(l), m_model.lattice_index.at(source[0], source[1]), {1.0, 1.0}};
      if (image.source < 0) throw std::logic_error("model_of: a mirror ghost kept without its source");
      image.sign[static_cast<std::size_t>(axis)] = -1.0;
      c.images.push_back(image);
    }
    if (c.images.empty()) return;
    std::stable_sort(c.images.begin(), c.images.end(),
                     [](const MirrorImage& x, const MirrorImage& y) { return x.source < y.source; });
    c.image_start.assign(n + 1, 0);
    for (const MirrorImage& im : c.images) ++c.image_start[static_cast<std::size_t>(im.source) + 1];
    for (std::size_t l = 0; l < n; ++l) c.image_start[l + 1] += c.image_start[l];
  }

  void build_bonds() {
    const Particles& p = m_model.particles;
    const Stencil& s = m_model.stencil;
    Bonds& bonds = m_model.bonds;
    const Index n = p.size();
    const double reach = m_model.horizon + m_dx;
    std::vector<char>& hold = m_model.family_held;
    if (!m_whole)
      for (const KeptPoint& k : m_kept) hold.push_back(k.held ? 1 : 0);
    const auto held = [&hold](Index i) { return hold.empty() || hold[static_cast<std::size_t>(i)]; };
    std::vector<int> stencil_index;  // per bond, while building
    std::vector<const Crack*> near;  // cracks whose box, grown by the reach, holds particle i
    Index n_held = 0;
    for (Index i = 0; i < n; ++i) n_held += held(i);
    const std::size_t capacity = static_cast<std::size_t>(n_held) * s.offset.size();  // an upper bound
    reserve_huge(bonds.neighbour, capacity);
    reserve_huge(stencil_index, capacity);
    bonds.start.assign(static_cast<std::size_t>(n) + 1, 0);
    bonds.stencil_weight = s.weight;
    bonds.own_start.assign(1, 0);
    bonds.own_start.reserve(static_cast<std::size_t>(n) + 1);
    std::vector<double> w;  // the family's weights
    for (Index i = 0; i < n; ++i) {
      w.clear();
      if (held(i)) add_family(i, near, reach, stencil_index, w);
      bonds.start[static_cast<std::size_t>(i) + 1] = static_cast<Index>(bonds.neighbour.size());
      bonds.add_weights(w);
    }
    if (m_whole) {
      m_model.n_bonds_whole = bonds.n_bonds();
    } else {
      m_model.n_cut_bonds = m_census.n_cut_bonds;
      m_model.n_bonds_whole = m_census.n_bonds();
      m_model.whole_start.reserve(static_cast<std::size_t>(n) + 1);
      for (const KeptPoint& k : m_kept) m_model.whole_start.push_back(k.first_bond);
      m_model.whole_start.push_back(m_model.n_bonds_whole);
    }
    pair_reverse_bonds(stencil_index);
    shrink_huge(bonds.neighbour);
    bonds.own_weight.shrink_to_fit();
  }

  /// Particle i's family: its stencil's particles of the same body whose bonds no pre-crack
  /// cuts (the whole model counts each cut pair once).
  void add_family(Index i, std::vector<const Crack*>& near, double reach, std::vector<int>& stencil_index,
                  std::vector<double>& weight) {
    const Particles& p = m_model.particles;
    const Stencil& s = m_model.stencil;
    Bonds& bonds = m_model.bonds;
    near.clear();
    for (const Crack& crack : m_scene.cracks) {
      const Vec2 lo = crack.a.cwiseMin(crack.b).array() - reach;
      const Vec2 hi = crack.a.cwiseMax(crack.b).array() + reach;
      if ((p.position[i].array() >= lo.array()).all() && (p.position[i].array() <= hi.array()).all())
        near.push_back(&crack);
    }
    for (std::size_t k = 0; k < s.offset.size(); ++k) {
      const int li = p.lattice[i][0] + s.offset[k][0], lj = p.lattice[i][1] + s.offset[k][1];
      const Index j = m_model.lattice_index.at(li, lj);
      if (j < 0) {
        if (m_census.at(li, lj).exists())
          throw std::logic_error("model_of: a held family's neighbour is not kept");
        continue;
      }
      if (p.body[j] != p.body[i]) continue;
      const bool cut = std::any_of(near.begin(), near.end(), [&](const Crack* c) {
        return bond_crosses_crack(p.position[i], p.position[j], c->a, c->b);
      });
      if (cut) {
        if (m_whole && i < j) ++m_model.n_cut_bonds;
        continue;
      }
      bonds.neighbour.push_back(j);
      weight.push_back(s.weight[k]);
      stencil_index.push_back(static_cast<int>(k));
    }
  }

  /// Fills bonds.reverse from each bond's stencil index (`stencil_index`); throws
  /// std::logic_error for a bond without its reverse.
  void pair_reverse_bonds(const std::vector<int>& stencil_index) {
    const Stencil& s = m_model.stencil;
    Bonds& bonds = m_model.bonds;
    const Index n = m_model.particles.size();
    // mirror[k]: the stencil index of -offset[k], the offset of the reverse bond.
    std::vector<Index>& mirror = bonds.stencil_mirror;
    mirror.resize(s.offset.size());
    for (std::size_t k = 0; k < s.offset.size(); ++k) {
      const auto it =
          std::find(s.offset.begin(), s.offset.end(), std::array<int, 2>{-s.offset[k][0], -s.offset[k][1]});
      mirror[k] = static_cast<Index>(it - s.offset.begin());
    }
    const std::vector<char>& hold = m_model.family_held;
    const auto held = [&hold](Index i) { return hold.empty() || hold[static_cast<std::size_t>(i)]; };
    // Reverse bonds: a family lists its bonds in increasing stencil index, so the bond
    // j -> i (stencil index mirror[k]) is found by binary search in j's family.
    std::vector<Index> reverse;
    assign_huge(reverse, bonds.neighbour.size(), Index{-1});
    Index unpaired = -1;  // a bond without its reverse (cut in one direction only): a defect
#pragma omp parallel for schedule(static) reduction(max : unpaired)
    for (Index i = 0; i < n; ++i) {
      for (Index b = bonds.start[i]; b < bonds.start[i + 1]; ++b) {
        const Index j = bonds.neighbour[b];
        if (!held(j)) continue;  // no reverse here (partitioned bonds)
        const auto first = stencil_index.begin() + bonds.start[j],
                   last = stencil_index.begin() + bonds.start[j + 1];
        const auto it = std::lower_bound(first, last, mirror[stencil_index[b]]);
        if (it == last || *it != mirror[stencil_index[b]]) {
          unpaired = std::max(unpaired, b);
          continue;
        }
        reverse[b] = static_cast<Index>(it - stencil_index.begin());
      }
    }
    if (unpaired >= 0)
      throw std::logic_error("discretise: bond " + std::to_string(unpaired) + " (to particle " +
                             std::to_string(bonds.neighbour[unpaired]) + ") has no reverse bond");
    bonds.set_reverse(reverse);
  }
};

}  // namespace

Stencil make_stencil(double horizon_factor, double spacing, Quadrature quadrature) {
  Stencil s;
  const double r = horizon_factor;
  const int reach = static_cast<int>(std::ceil(r + 0.5));
  std::vector<double> fraction;
  for (int i = -reach; i <= reach; ++i) {
    for (int j = -reach; j <= reach; ++j) {
      if (i == 0 && j == 0) continue;
      double f = 0.0;
      if (quadrature == Quadrature::full) {
        f = (i * i + j * j <= r * r * (1.0 + 1e-12)) ? 1.0 : 0.0;
      } else {
        f = cell_area_in_disc(i, j, r);
      }
      if (f <= 1e-12) continue;
      s.offset.push_back({i, j});
      fraction.push_back(f);
      s.reach = std::max({s.reach, std::abs(i), std::abs(j)});
    }
  }
  // Fourth-harmonic correction: weights f (1 + beta cos 4 phi) with beta chosen so that
  // sum f (1 + beta cos 4phi) |xi|^2 cos 4phi = 0, which makes the fourth moments of the
  // bond direction isotropic (docs/theory/osb.md, "Quadrature").
  if (quadrature == Quadrature::isotropic) {
    double num = 0.0, den = 0.0;
    for (std::size_t k = 0; k < s.offset.size(); ++k) {
      const double x = s.offset[k][0], y = s.offset[k][1];
      const double r2 = x * x + y * y;
      const double c4 = std::cos(4.0 * std::atan2(y, x));
      num += fraction[k] * r2 * c4;
      den += fraction[k] * r2 * c4 * c4;
    }
    s.beta = den > 0.0 ? -num / den : 0.0;
  }
  const double cell = spacing * spacing;
  for (std::size_t k = 0; k < s.offset.size(); ++k) {
    const double c4 = std::cos(4.0 * std::atan2(double(s.offset[k][1]), double(s.offset[k][0])));
    s.weight.push_back(cell * fraction[k] * (1.0 + s.beta * c4));
  }
  return s;
}

namespace {

/// The width of "on the crack line", relative to the largest coordinate involved: the
/// coordinates carry round-off of a few units of 2^-53 of their magnitude (a lattice point
/// is origin + i dx, a crack end a decimal), so a point whose exact position is on the line
/// is computed within about 1e-15 of that scale of it. 1e-12 is 500 times that and, for any
/// lattice of fewer than 10^6 cells from the coordinates' origin, below 1e-6 dx.
constexpr double kOnCrackLine = 1e-12;

/// The side of point p of the line through a in direction d: +1 left, -1 right, 0 on it
/// within kOnCrackLine of the largest coordinate. A function of (p, a, d) alone, so a
/// particle is on one side for every bond it has.
int side_of_crack_line(const Vec2& p, const Vec2& a, const Vec2& d, double scale) {
  const double s = cross(d, p - a);  // |d| times the signed distance
  const double band = kOnCrackLine * std::max(scale, p.cwiseAbs().maxCoeff()) * d.norm();
  return s > band ? 1 : (s < -band ? -1 : 0);
}

}  // namespace

bool bond_crosses_crack(const Vec2& p, const Vec2& q, const Vec2& a, const Vec2& b) {
  // The same answer for (p, q) and (q, p), by construction: the crossing point below is
  // computed from p. Computed from either end, a bond through a crack tip was cut in one
  // direction only, and the reverse of the other pointed at a wrong bond of the neighbour's family.
  if (q.x() < p.x() || (q.x() == p.x() && q.y() < p.y())) return bond_crosses_crack(q, p, a, b);
  // A point on the crack line, up to the round-off of the coordinates, counts as lying on its
  // left side, so a particle on the crack is on one face, never on both, and which face does
  // not depend on how the machine rounds (docs/theory/osb.md, "Pre-cracks").
  const Vec2 d = b - a;
  const double scale = std::max({a.cwiseAbs().maxCoeff(), b.cwiseAbs().maxCoeff(), d.norm()});
  const int sp = side_of_crack_line(p, a, d, scale), sq = side_of_crack_line(q, a, d, scale);
  if ((sp >= 0) == (sq >= 0)) return false;
  // The crossing with the crack line: an end on the line is the crossing itself.
  Vec2 x = sp == 0 ? p : q;
  if (sp != 0 && sq != 0) {
    const double cp = cross(d, p - a), cq = cross(d, q - a);
    x = p + (q - p) * (cp / (cp - cq));
  }
  // The crack is a closed segment: a crossing at a tip, up to the same round-off, cuts.
  const double length = d.norm(), along = (x - a).dot(d) / length;
  const double band = kOnCrackLine * std::max(scale, x.cwiseAbs().maxCoeff());
  return along >= -band && along <= length + band;
}

bool inside_polygon(const Polygon& polygon, const Vec2& p) {
  bool inside = false;
  const std::size_t n = polygon.vertices.size();
  for (std::size_t k = 0; k < n; ++k) {
    Vec2 a = polygon.vertices[k], b = polygon.vertices[(k + 1) % n];
    if (a.y() > b.y()) std::swap(a, b);  // canonical order: identical arithmetic for shared edges
    if (!(a.y() <= p.y() && p.y() < b.y())) continue;
    if (cross(b - a, p - a) > 0.0) inside = !inside;  // the edge crosses the ray p + t e_x, t > 0
  }
  return inside;
}

Model model_of(const ModelDescription& scene, const LatticeCensus& census, const std::vector<KeptPoint>& kept,
               bool whole, std::vector<std::int64_t>* global_unknown) {
  if (!whole && !census.families_counted)
    throw std::logic_error("model_of: a part needs a census that counted the families");
  return ModelMaker(scene, census, kept, whole).build(global_unknown);
}

Model discretise(const ModelDescription& scene) {
  const LatticeCensus census = take_census(scene, false);
  // Every point, in the order of the particles' numbers (they are 0 .. N-1).
  std::vector<KeptPoint> lattice_order = number_points(census, [](int, int, std::int64_t) { return true; });
  std::vector<KeptPoint> kept(lattice_order.size());
  for (const KeptPoint& k : lattice_order) kept[static_cast<std::size_t>(k.id)] = k;
  std::vector<KeptPoint>().swap(lattice_order);
  return model_of(scene, census, kept, true);
}

std::vector<char> within_stencil(const Model& model, const std::vector<char>& seeds) {
  const Particles& p = model.particles;
  const Index n = p.size();
  std::vector<char> near(static_cast<std::size_t>(n), 0);
  for (Index i = 0; i < n; ++i) {
    if (!seeds[static_cast<std::size_t>(i)]) continue;
    near[static_cast<std::size_t>(i)] = 1;
    for (const auto& o : model.stencil.offset)
      if (const Index j = model.lattice_index.at(p.lattice[i][0] + o[0], p.lattice[i][1] + o[1]); j >= 0)
        near[static_cast<std::size_t>(j)] = 1;
  }
  return near;
}

void Constraints::expand(const VectorXd& x, double lambda, VectorXd& u) const {
  u.resize(static_cast<Index>(prescribed.size()));
  for (std::size_t d = 0; d < prescribed.size(); ++d)
    u[d] = prescribed[d] ? lambda * value[d] : x[free_index[d]];
  for (const MirrorImage& im : images)  // a source is never a ghost: its u is final here
    for (int c = 0; c < 2; ++c) u[2 * im.ghost + c] += im.sign[c] * u[2 * im.source + c];
}

void Constraints::scatter(const VectorXd& x, VectorXd& full) const {
  full.resize(static_cast<Index>(free_index.size()));
  for (std::size_t d = 0; d < free_index.size(); ++d) full[d] = free_index[d] >= 0 ? x[free_index[d]] : 0.0;
  for (const MirrorImage& im : images)
    for (int c = 0; c < 2; ++c) full[2 * im.ghost + c] = im.sign[c] * full[2 * im.source + c];
}

int mirror_layers(double horizon_factor) {
  return 2 * static_cast<int>(std::ceil(horizon_factor + 0.5));
}

void Constraints::gather(const VectorXd& full, VectorXd& x) const {
  x.resize(n_free);
  for (std::size_t d = 0; d < free_index.size(); ++d)
    if (free_index[d] >= 0) x[free_index[d]] = full[d];
}

void Bonds::add_weights(std::span<const double> w) {
  if (w.size() == stencil_weight.size()) {
    // Every stencil bond, in stencil order: the stencil's weights.
    if (!std::equal(w.begin(), w.end(), stencil_weight.begin()))
      throw std::logic_error("Bonds::add_weights: a whole family's weights are not the stencil's");
  } else {
    own_weight.insert(own_weight.end(), w.begin(), w.end());
  }
  own_start.push_back(static_cast<Index>(own_weight.size()));
}

void Bonds::set_reverse(std::span<const Index> every) {
  const Index n = static_cast<Index>(start.size()) - 1;
  const auto whole = [&](Index i) {
    return static_cast<std::size_t>(family_size(i)) == stencil_weight.size();
  };
  own_reverse_start.assign(1, 0);
  own_reverse_start.reserve(static_cast<std::size_t>(n) + 1);
  own_reverse.clear();
  for (Index i = 0; i < n; ++i) {
    bool computed = whole(i);
    for (Index b = start[i]; computed && b < start[i + 1]; ++b) computed = whole(neighbour[b]);
    if (computed) {
      for (Index b = start[i]; b < start[i + 1]; ++b)
        if (every[static_cast<std::size_t>(b)] !=
            start[neighbour[b]] + stencil_mirror[static_cast<std::size_t>(b - start[i])])
          throw std::logic_error("Bonds::set_reverse: bond " + std::to_string(b) +
                                 "'s reverse is not its mirror's");
    } else {
      own_reverse.insert(own_reverse.end(), every.begin() + start[i], every.begin() + start[i + 1]);
    }
    own_reverse_start.push_back(static_cast<Index>(own_reverse.size()));
  }
  own_reverse.shrink_to_fit();
}

std::vector<double> Bonds::every_weight() const {
  std::vector<double> all;
  all.reserve(neighbour.size());
  for (Index i = 0; i + 1 < static_cast<Index>(start.size()); ++i) {
    const std::span<const double> w = weights(i);
    all.insert(all.end(), w.begin(), w.end());
  }
  return all;
}

std::span<const Vec2> Model::family_xi(Index i) const {
  thread_local std::vector<Vec2> buffer;
  const Index b0 = bonds.start[i], nb = bonds.family_size(i);
  if (buffer.size() < static_cast<std::size_t>(nb)) buffer.resize(static_cast<std::size_t>(nb));
  for (Index k = 0; k < nb; ++k) buffer[k] = xi(i, b0 + k);
  return std::span<const Vec2>(buffer.data(), static_cast<std::size_t>(nb));
}

std::size_t Model::memory_bytes() const {
  auto bytes = [](const auto& v) { return v.capacity() * sizeof(v[0]); };
  const Particles& p = particles;
  return bytes(p.position) + bytes(p.volume) + bytes(p.body) + bytes(p.fictitious) + bytes(p.lattice) +
         bytes(bonds.start) + bytes(bonds.neighbour) + bytes(bonds.stencil_weight) + bytes(bonds.own_start) +
         bytes(bonds.own_weight) + bytes(bonds.stencil_mirror) + bytes(bonds.own_reverse_start) +
         bytes(bonds.own_reverse) + bytes(family_held) + bytes(whole_start) + bytes(constraints.prescribed) +
         bytes(constraints.value) + bytes(constraints.free_index) + bytes(constraints.images) +
         bytes(constraints.image_start) +
         [&] {
           std::size_t b = 0;
           for (const auto& dofs : constraints.condition_dofs) b += bytes(dofs);
           return b;
         }() +
         lattice_index.memory_bytes();
}

}  // namespace peristat
