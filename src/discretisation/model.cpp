#include "discretisation/model.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <string>

#include "core/huge_pages.hpp"
#include "core/geometry.hpp"

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

struct Box {
  Vec2 lo{std::numeric_limits<double>::max(), std::numeric_limits<double>::max()};
  Vec2 hi{-std::numeric_limits<double>::max(), -std::numeric_limits<double>::max()};
  void add(const Vec2& p) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
};

Box polygon_box(const Polygon& polygon) {
  Box box;
  for (const Vec2& v : polygon.vertices) box.add(v);
  return box;
}

double cross(const Vec2& a, const Vec2& b) {
  return a.x() * b.y() - a.y() * b.x();
}

double distance_to_boundary(const Polygon& polygon, const Vec2& p) {
  double d = std::numeric_limits<double>::max();
  const std::size_t n = polygon.vertices.size();
  for (std::size_t k = 0; k < n; ++k)
    d = std::min(d, geometry::distance_to_segment(p, polygon.vertices[k], polygon.vertices[(k + 1) % n]));
  return d;
}

/// Builder state shared by the steps of discretise().
class Builder {
 public:
  Builder(const ModelDescription& scene, const FamilySelector& select)
      : m_scene(scene), m_select(select), m_dx(scene.discretization.spacing) {
    for (const Body& body : scene.bodies)
      m_model.bodies.push_back({body.name, scene.materials.at(body.material), body.shape});
    m_model.cracks = scene.cracks;
    Box box;
    for (const Body& body : scene.bodies) {
      const Box b = polygon_box(body.shape);
      box.add(b.lo);
      box.add(b.hi);
    }
    for (const BoundaryCondition& bc : scene.boundary) {
      if (bc.selector != BoundaryCondition::Selector::block) continue;
      box.add(bc.lo);
      box.add(bc.hi);
    }
    int max_layers = scene.discretization.fictitious_layers;
    for (const BoundaryCondition& bc : scene.boundary) max_layers = std::max(max_layers, layers_of(bc));
    const int pad = max_layers + 2;
    m_model.lattice_index =
        LatticeIndex(lattice_floor(box.lo.x(), 0) - pad, lattice_floor(box.lo.y(), 1) - pad,
                     lattice_floor(box.hi.x(), 0) + pad, lattice_floor(box.hi.y(), 1) + pad);
  }

  Model build() {
    m_model.spacing = m_dx;
    m_model.horizon = m_scene.discretization.horizon_factor * m_dx;
    for (std::size_t b = 0; b < m_scene.bodies.size(); ++b) add_body(static_cast<int>(b));
    std::vector<std::vector<Index>> selected(m_scene.boundary.size());
    for (std::size_t k = 0; k < m_scene.boundary.size(); ++k) selected[k] = select(m_scene.boundary[k]);
    apply_constraints(selected);
    m_model.stencil =
        make_stencil(m_scene.discretization.horizon_factor, m_dx, m_scene.discretization.quadrature);
    number_unknowns();
    index_images();
    record_condition_dofs();
    if (m_select) m_model.family_held = m_select(m_model);
    build_bonds();
    return std::move(m_model);
  }

 private:
  const ModelDescription& m_scene;
  const FamilySelector& m_select;
  double m_dx;
  Model m_model;
  std::vector<int> m_owner;  ///< per component, the condition that prescribes it (-1: free)

  int layers_of(const BoundaryCondition& bc) const {
    return bc.mirror ? mirror_layers(m_scene.discretization.horizon_factor) : bc.layers;
  }

  int lattice_floor(double x, int axis) const {
    return static_cast<int>(std::floor((x - m_scene.discretization.origin[axis]) / m_dx - 0.5));
  }
  Vec2 lattice_point(int i, int j) const {
    return m_scene.discretization.origin + Vec2((i + 0.5) * m_dx, (j + 0.5) * m_dx);
  }

  Index add_particle(int body, int i, int j, bool fictitious) {
    Particles& p = m_model.particles;
    const Index id = p.size();
    const Material& material = m_scene.materials.at(m_scene.bodies[body].material);
    p.position.push_back(lattice_point(i, j));
    p.volume.push_back(m_dx * m_dx * material.thickness);
    p.body.push_back(body);
    p.fictitious.push_back(fictitious ? 1 : 0);
    p.lattice.push_back({i, j});
    m_model.lattice_index.set(i, j, id);
    return id;
  }

  void add_body(int b) {
    const Body& body = m_scene.bodies[b];
    const Box box = polygon_box(body.shape);
    Index count = 0;
    for (int i = lattice_floor(box.lo.x(), 0); i <= lattice_floor(box.hi.x(), 0) + 1; ++i) {
      for (int j = lattice_floor(box.lo.y(), 1); j <= lattice_floor(box.hi.y(), 1) + 1; ++j) {
        if (!inside_polygon(body.shape, lattice_point(i, j))) continue;
        const Index other = m_model.lattice_index.at(i, j);
        if (other >= 0) {
          throw InputError(body.where, "body '" + body.name + "' overlaps body '" +
                                           m_scene.bodies[m_model.particles.body[other]].name +
                                           "' (they share the lattice point at " +
                                           format_point(lattice_point(i, j)) + ")");
        }
        add_particle(b, i, j, false);
        ++count;
      }
    }
    if (count == 0) {
      throw InputError(body.where, "body '" + body.name +
                                       "' contains no lattice point: it is smaller than the spacing "
                                       "discretization.spacing = " +
                                       std::to_string(m_dx));
    }
  }

  static std::string format_point(const Vec2& p) {
    char buf[96];
    std::snprintf(buf, sizeof buf, "(%.6g, %.6g)", p.x(), p.y());
    return buf;
  }

  /// The particle at lattice point (i, j) as a fictitious particle of `body`, created if
  /// absent. Throws when the point belongs to something else.
  Index fictitious_at(const BoundaryCondition& bc, int body, int i, int j) {
    const Index existing = m_model.lattice_index.at(i, j);
    if (existing < 0) return add_particle(body, i, j, true);
    const Particles& p = m_model.particles;
    if (p.body[existing] == body && p.fictitious[existing]) return existing;
    throw InputError(bc.where, "the fictitious layers of this condition overlap body '" +
                                   m_scene.bodies[p.body[existing]].name + "' at " +
                                   format_point(p.position[existing]));
  }

  /// The index of the body a condition names (the parser has checked that it exists).
  int body_of(const BoundaryCondition& bc) const {
    const auto it = std::find_if(m_scene.bodies.begin(), m_scene.bodies.end(),
                                 [&](const Body& b) { return b.name == bc.body; });
    return static_cast<int>(it - m_scene.bodies.begin());
  }

  /// The particles condition `bc` selects (its fictitious ones created); throws when none.
  std::vector<Index> select(const BoundaryCondition& bc) {
    const int body = body_of(bc);
    std::vector<Index> chosen;
    const double eps = 1e-9 * m_dx;
    const auto in_box = [&](const Vec2& x) {  // selectors region and block
      return (x.array() >= bc.lo.array() - eps).all() && (x.array() <= bc.hi.array() + eps).all();
    };
    if (bc.selector == BoundaryCondition::Selector::region) {
      const Particles& p = m_model.particles;
      for (Index q = 0; q < p.size(); ++q) {
        if (p.body[q] != body || p.fictitious[q]) continue;
        const Vec2& x = p.position[q];
        if (in_box(x)) chosen.push_back(q);
      }
    } else if (bc.selector == BoundaryCondition::Selector::block) {
      // Lattice points inside the box; those of a body are not fictitious and are refused
      // by fictitious_at with a message naming the body.
      for (int i = lattice_floor(bc.lo.x() - eps, 0); i <= lattice_floor(bc.hi.x() + eps, 0) + 1; ++i) {
        for (int j = lattice_floor(bc.lo.y() - eps, 1); j <= lattice_floor(bc.hi.y() + eps, 1) + 1; ++j) {
          const Vec2 x = lattice_point(i, j);
          if (in_box(x)) chosen.push_back(fictitious_at(bc, body, i, j));
        }
      }
    } else {
      select_edge(bc, body, eps, chosen);
    }
    if (chosen.empty()) {
      throw InputError(bc.where, "this condition selects no particle of body '" + bc.body +
                                     "' (check the edge, region or layers)");
    }
    return chosen;
  }

  /// The particles of an edge or surround condition on `body` into `chosen`: its own outermost
  /// (layers 0) or the fictitious layers outside (created as needed); `eps` the lattice tolerance.
  void select_edge(const BoundaryCondition& bc, int body, double eps, std::vector<Index>& chosen) {
    const Polygon& shape = m_scene.bodies[body].shape;
    // edge and surround: the edge's frame (counter-clockwise polygon, outward normal).
    const std::size_t n = shape.vertices.size();
    Vec2 a = Vec2::Zero(), b = Vec2::Zero();
    if (bc.selector == BoundaryCondition::Selector::edge) {
      a = shape.vertices[bc.edge];
      b = shape.vertices[(bc.edge + 1) % n];
    }
    const Vec2 tangent = (b - a).normalized();
    const Vec2 outward(tangent.y(), -tangent.x());
    const double length = (b - a).norm();
    const auto along_edge = [&](const Vec2& x) {
      const double t = tangent.dot(x - a);
      return t >= -eps && t <= length + eps;
    };
    if (bc.layers == 0) {
      // The body's own outermost particles: inside, within one spacing of the edge line
      // (edge) or of the boundary (surround).
      const Particles& p = m_model.particles;
      for (Index q = 0; q < p.size(); ++q) {
        if (p.body[q] != body || p.fictitious[q]) continue;
        const Vec2& x = p.position[q];
        bool take = false;
        if (bc.selector == BoundaryCondition::Selector::edge) {
          const double d = -outward.dot(x - a);
          take = d > -eps && d <= m_dx + eps && along_edge(x);
        } else {
          take = distance_to_boundary(shape, x) <= m_dx + eps;
        }
        if (take) chosen.push_back(q);
      }
    } else {
      const double depth = layers_of(bc) * m_dx;
      const Box box = polygon_box(shape);
      for (int i = lattice_floor(box.lo.x() - depth, 0) - 1; i <= lattice_floor(box.hi.x() + depth, 0) + 1;
           ++i) {
        for (int j = lattice_floor(box.lo.y() - depth, 1) - 1;
             j <= lattice_floor(box.hi.y() + depth, 1) + 1; ++j) {
          const Vec2 x = lattice_point(i, j);
          if (inside_polygon(shape, x)) continue;
          bool take = false;
          if (bc.selector == BoundaryCondition::Selector::edge) {
            const double d = outward.dot(x - a);
            take = d > 0.0 && d <= depth + eps && along_edge(x);
          } else {
            take = distance_to_boundary(shape, x) <= depth + eps;
          }
          if (take) chosen.push_back(fictitious_at(bc, body, i, j));
        }
      }
    }
  }

  void apply_constraints(const std::vector<std::vector<Index>>& selected) {
    Constraints& c = m_model.constraints;
    const Index n = m_model.particles.size();
    c.prescribed.assign(2 * static_cast<std::size_t>(n), 0);
    c.value.assign(2 * static_cast<std::size_t>(n), 0.0);
    std::vector<int>& owner = m_owner;
    owner.assign(2 * static_cast<std::size_t>(n), -1);
    for (std::size_t k = 0; k < selected.size(); ++k) {
      const BoundaryCondition& bc = m_scene.boundary[k];
      if (bc.mirror) {
        apply_mirror(bc, selected[k], owner, static_cast<int>(k));
        continue;
      }
      for (Index q : selected[k]) {
        for (int comp = 0; comp < 2; ++comp) {
          const std::optional<AffineValue>& v = comp == 0 ? bc.ux : bc.uy;
          if (!v) continue;
          const std::size_t dof = 2 * static_cast<std::size_t>(q) + comp;
          if (owner[dof] >= 0) {
            throw InputError(bc.where, std::string("prescribes u") + (comp == 0 ? "x" : "y") +
                                           " of the particle at " +
                                           format_point(m_model.particles.position[q]) + ", which " +
                                           m_scene.boundary[owner[dof]].where.key + " already prescribes");
          }
          owner[dof] = static_cast<int>(k);
          c.prescribed[dof] = 1;
          c.value[dof] = v->at(m_model.particles.position[q]);
        }
      }
    }
  }

  /// A mirror condition: every ghost reflects a real particle across the edge line; the
  /// normal component is 2 U - u_n(source), the tangential one u_t(source).
  void apply_mirror(const BoundaryCondition& bc, const std::vector<Index>& ghosts, std::vector<int>& owner,
                    int k) {
    const Body& body = m_scene.bodies[body_of(bc)];
    const std::size_t nv = body.shape.vertices.size();
    const Vec2 a = body.shape.vertices[bc.edge], b = body.shape.vertices[(bc.edge + 1) % nv];
    const Vec2 d = b - a;
    const double tol = 1e-9 * d.norm();
    if (std::abs(d.x()) > tol && std::abs(d.y()) > tol)
      throw InputError(bc.where, "mirror needs an edge parallel to x or y; edge " + bc.edge_name +
                                     " runs from " + format_point(a) + " to " + format_point(b));
    const int axis = std::abs(d.x()) <= tol ? 0 : 1;  // the normal's axis (0: a vertical edge)
    const char* normal = axis == 0 ? "ux" : "uy";
    const char* tangential = axis == 0 ? "uy" : "ux";
    const std::optional<AffineValue>& un = axis == 0 ? bc.ux : bc.uy;
    const std::optional<AffineValue>& ut = axis == 0 ? bc.uy : bc.ux;
    if (ut || !un)
      throw InputError(bc.where, std::string("a mirror on edge ") + bc.edge_name + " prescribes only the normal component " +
                                     normal + " (the platen's displacement); " + tangential +
                                     " is the reflected body's own");
    const double reach = mirror_layers(m_scene.discretization.horizon_factor) * m_dx;
    for (const Crack& crack : m_scene.cracks) {
      const double gap =
          bond_crosses_crack(a, b, crack.a, crack.b)
              ? 0.0
              : std::min({geometry::distance_to_segment(crack.a, a, b), geometry::distance_to_segment(crack.b, a, b),
                          geometry::distance_to_segment(a, crack.a, crack.b),
                          geometry::distance_to_segment(b, crack.a, crack.b)});
      if (gap < reach)
        throw InputError(bc.where, "a pre-crack passes " + std::to_string(gap) + " m from mirror edge " +
                                       bc.edge_name + ", within the mirrored depth " + std::to_string(reach) +
                                       " m: the reflected layers would not hold the crack");
    }
    // The edge line must be a lattice cell boundary for the reflection of a lattice point to
    // be a lattice point.
    const double line = (a[axis] - m_scene.discretization.origin[axis]) / m_dx;
    const long line_index = std::lround(line);
    if (std::abs(line - static_cast<double>(line_index)) > 1e-6)
      throw InputError(bc.where, std::string("mirror needs the edge line on a lattice cell boundary: ") +
                                     (axis == 0 ? "x" : "y") + " = " + std::to_string(a[axis]) +
                                     " is " + std::to_string(line) +
                                     " spacings from discretization.origin, not a whole number");
    Constraints& c = m_model.constraints;
    const Particles& p = m_model.particles;
    for (Index g : ghosts) {
      std::array<int, 2> l = p.lattice[g];
      l[axis] = static_cast<int>(2 * line_index - l[axis] - 1);
      const Index source = m_model.lattice_index.at(l[0], l[1]);
      if (source < 0 || p.fictitious[source] || p.body[source] != p.body[g])
        throw InputError(bc.where, "the body is thinner than two horizons across edge " + bc.edge_name +
                                       ": the mirror image of " + format_point(p.position[g]) +
                                       " is not a particle of body '" + bc.body + "'");
      Vec2 foot = p.position[g];
      foot[axis] = a[axis];
      MirrorImage image{g, source, {1.0, 1.0}};
      image.sign[axis] = -1.0;
      for (int comp = 0; comp < 2; ++comp) {
        const std::size_t dof = 2 * static_cast<std::size_t>(g) + comp;
        if (owner[dof] >= 0)
          throw InputError(bc.where, "the mirror layers overlap the particles that " +
                                         m_scene.boundary[owner[dof]].where.key + " prescribes");
        owner[dof] = k;
        c.prescribed[dof] = 1;
        c.value[dof] = comp == axis ? 2.0 * un->at(foot) : 0.0;
      }
      c.images.push_back(image);
    }
  }

  void record_condition_dofs() {
    Constraints& c = m_model.constraints;
    c.condition_dofs.assign(m_scene.boundary.size(), {});
    for (std::size_t d = 0; d < m_owner.size(); ++d)
      if (m_owner[d] >= 0) c.condition_dofs[m_owner[d]].push_back(static_cast<Index>(d));
    std::vector<int>().swap(m_owner);
  }

  void index_images() {
    Constraints& c = m_model.constraints;
    if (c.images.empty()) return;
    std::sort(c.images.begin(), c.images.end(),
              [](const MirrorImage& x, const MirrorImage& y) { return x.source < y.source; });
    const Index n = m_model.particles.size();
    c.image_start.assign(n + 1, 0);
    for (const MirrorImage& im : c.images) ++c.image_start[im.source + 1];
    for (Index i = 0; i < n; ++i) c.image_start[i + 1] += c.image_start[i];
  }

  void build_bonds() {
    const Particles& p = m_model.particles;
    const Stencil& s = m_model.stencil;
    Bonds& bonds = m_model.bonds;
    const Index n = p.size();
    const double reach = m_model.horizon + m_dx;
    const std::vector<char>& hold = m_model.family_held;
    const auto held = [&hold](Index i) { return hold.empty() || hold[static_cast<std::size_t>(i)]; };
    std::vector<int> stencil_index;  // per bond, while building
    std::vector<const Crack*> near;  // cracks whose box, grown by the reach, holds particle i
    Index n_held = 0;
    for (Index i = 0; i < n; ++i) n_held += held(i);
    const std::size_t capacity = static_cast<std::size_t>(n_held) * s.offset.size();  // an upper bound
    reserve_huge(bonds.neighbour, capacity);
    reserve_huge(bonds.xi, capacity);
    reserve_huge(bonds.weight, capacity);
    reserve_huge(stencil_index, capacity);
    bonds.start.assign(n + 1, 0);
    if (!hold.empty()) m_model.whole_start.assign(static_cast<std::size_t>(n) + 1, 0);
    for (Index i = 0; i < n; ++i) {
      near.clear();
      for (const Crack& crack : m_scene.cracks) {
        const Vec2 lo = crack.a.cwiseMin(crack.b).array() - reach;
        const Vec2 hi = crack.a.cwiseMax(crack.b).array() + reach;
        if ((p.position[i].array() >= lo.array()).all() && (p.position[i].array() <= hi.array()).all())
          near.push_back(&crack);
      }
      for (std::size_t k = 0; k < s.offset.size(); ++k) {
        const Index j =
            m_model.lattice_index.at(p.lattice[i][0] + s.offset[k][0], p.lattice[i][1] + s.offset[k][1]);
        if (j < 0 || p.body[j] != p.body[i]) continue;
        const bool cut = std::any_of(near.begin(), near.end(), [&](const Crack* c) {
          return bond_crosses_crack(p.position[i], p.position[j], c->a, c->b);
        });
        if (cut) {
          if (i < j) ++m_model.n_cut_bonds;
          continue;
        }
        ++m_model.n_bonds_whole;
        if (!held(i)) continue;
        bonds.neighbour.push_back(j);
        bonds.xi.push_back(p.position[j] - p.position[i]);
        bonds.weight.push_back(s.weight[k]);
        stencil_index.push_back(static_cast<int>(k));
      }
      bonds.start[i + 1] = static_cast<Index>(bonds.neighbour.size());
      if (!hold.empty()) m_model.whole_start[static_cast<std::size_t>(i) + 1] = m_model.n_bonds_whole;
    }
    pair_reverse_bonds(stencil_index);
    shrink_huge(bonds.neighbour);
    shrink_huge(bonds.xi);
    shrink_huge(bonds.weight);
  }

  /// Fills bonds.reverse from each bond's stencil index (`stencil_index`); throws
  /// std::logic_error for a bond without its reverse.
  void pair_reverse_bonds(const std::vector<int>& stencil_index) {
    const Stencil& s = m_model.stencil;
    Bonds& bonds = m_model.bonds;
    const Index n = m_model.particles.size();
    // mirror[k]: the stencil index of -offset[k], the offset of the reverse bond.
    std::vector<int> mirror(s.offset.size());
    for (std::size_t k = 0; k < s.offset.size(); ++k) {
      const auto it =
          std::find(s.offset.begin(), s.offset.end(), std::array<int, 2>{-s.offset[k][0], -s.offset[k][1]});
      mirror[k] = static_cast<int>(it - s.offset.begin());
    }
    const std::vector<char>& hold = m_model.family_held;
    const auto held = [&hold](Index i) { return hold.empty() || hold[static_cast<std::size_t>(i)]; };
    // Reverse bonds: a family lists its bonds in increasing stencil index, so the bond
    // j -> i (stencil index mirror[k]) is found by binary search in j's family.
    assign_huge(bonds.reverse, bonds.neighbour.size(), Index{-1});
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
        bonds.reverse[b] = static_cast<Index>(it - stencil_index.begin());
      }
    }
    if (unpaired >= 0)
      throw std::logic_error("discretise: bond " + std::to_string(unpaired) + " (to particle " +
                             std::to_string(bonds.neighbour[unpaired]) + ") has no reverse bond");
  }

  void number_unknowns() {
    Constraints& c = m_model.constraints;
    c.free_index.assign(c.prescribed.size(), -1);
    Index next = 0;
    for (std::size_t d = 0; d < c.prescribed.size(); ++d)
      if (!c.prescribed[d]) c.free_index[d] = next++;
    c.n_free = next;
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

bool bond_crosses_crack(const Vec2& p, const Vec2& q, const Vec2& a, const Vec2& b) {
  // The same answer for (p, q) and (q, p), by construction: the crossing point below is
  // computed from p, and where the bond passes through a crack tip (u = 0 or 1 exactly) its
  // round-off decides. Computed from either end, a bond through a tip was cut in one direction
  // only, and the reverse of the other pointed at a wrong bond of the neighbour's family.
  if (q.x() < p.x() || (q.x() == p.x() && q.y() < p.y())) return bond_crosses_crack(q, p, a, b);
  // A point on the crack line counts as lying on its left (non-negative) side, so a
  // particle exactly on the crack is on one face, never on both.
  const Vec2 d = b - a;
  const double sp = cross(d, p - a), sq = cross(d, q - a);
  if ((sp >= 0.0) == (sq >= 0.0)) return false;
  const Vec2 x = p + (q - p) * (sp / (sp - sq));  // crossing with the crack line
  const double u = (x - a).dot(d) / d.squaredNorm();
  return u >= 0.0 && u <= 1.0;
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

Model discretise(const ModelDescription& scene) {
  return Builder(scene, FamilySelector{}).build();
}

Model discretise(const ModelDescription& scene, const FamilySelector& select) {
  return Builder(scene, select).build();
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

std::size_t Model::memory_bytes() const {
  auto bytes = [](const auto& v) { return v.capacity() * sizeof(v[0]); };
  const Particles& p = particles;
  return bytes(p.position) + bytes(p.volume) + bytes(p.body) + bytes(p.fictitious) + bytes(p.lattice) +
         bytes(bonds.start) + bytes(bonds.neighbour) + bytes(bonds.xi) + bytes(bonds.weight) +
         bytes(bonds.reverse) + bytes(family_held) + bytes(whole_start) + bytes(constraints.prescribed) +
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
