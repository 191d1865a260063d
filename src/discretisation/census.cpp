#include "discretisation/census.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <optional>
#include <stdexcept>
#include <string>

#include "core/error.hpp"
#include "core/geometry.hpp"

namespace peristat {

namespace {

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

double distance_to_boundary(const Polygon& polygon, const Vec2& p) {
  double d = std::numeric_limits<double>::max();
  const std::size_t n = polygon.vertices.size();
  for (std::size_t k = 0; k < n; ++k)
    d = std::min(d, geometry::distance_to_segment(p, polygon.vertices[k], polygon.vertices[(k + 1) % n]));
  return d;
}

std::string format_point(const Vec2& p) {
  char buf[96];
  std::snprintf(buf, sizeof buf, "(%.6g, %.6g)", p.x(), p.y());
  return buf;
}

/// The steps of take_census(): the bodies' particles, then each condition's selection (its
/// fictitious particles created), then each condition's components, then the families.
class CensusBuilder {
 public:
  CensusBuilder(const ModelDescription& scene) : m_scene(scene), m_dx(scene.discretization.spacing) {
    LatticeCensus& c = m_census;
    if (scene.bodies.size() + scene.boundary.size() + 1 > std::numeric_limits<std::uint16_t>::max())
      throw InputError("a scene has at most 65534 bodies and boundary conditions together");
    c.spacing = m_dx;
    c.origin = scene.discretization.origin;
    c.n_bodies = static_cast<int>(scene.bodies.size());
    c.group_body.assign(1, -1);
    for (int b = 0; b < c.n_bodies; ++b) c.group_body.push_back(b);
    for (const BoundaryCondition& bc : scene.boundary) c.group_body.push_back(body_of(bc));
    c.mirror_axis.assign(scene.boundary.size(), -1);
    c.mirror_line.assign(scene.boundary.size(), 0);
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
    c.i0 = lattice_floor(box.lo.x(), 0) - pad;
    c.j0 = lattice_floor(box.lo.y(), 1) - pad;
    c.ni = lattice_floor(box.hi.x(), 0) + pad - c.i0 + 1;
    c.nj = lattice_floor(box.hi.y(), 1) + pad - c.j0 + 1;
    c.point.assign(static_cast<std::size_t>(c.ni) * static_cast<std::size_t>(c.nj), CensusPoint{});
  }

  LatticeCensus build(bool count_families) {
    for (std::size_t b = 0; b < m_scene.bodies.size(); ++b) add_body(static_cast<int>(b));
    // Every condition's particles first (its fictitious ones created, none missing), then
    // the components: a condition's message names the first problem in the scene's order.
    for (std::size_t k = 0; k < m_scene.boundary.size(); ++k)
      if (select(static_cast<int>(k), [](std::size_t) {}) == 0)
        throw InputError(m_scene.boundary[k].where, "this condition selects no particle of body '" +
                                                        m_scene.boundary[k].body +
                                                        "' (check the edge, region or layers)");
    for (std::size_t k = 0; k < m_scene.boundary.size(); ++k) apply_condition(static_cast<int>(k));
    m_census.stencil =
        make_stencil(m_scene.discretization.horizon_factor, m_dx, m_scene.discretization.quadrature);
    count_groups();
    if (count_families) this->count_families();
    return std::move(m_census);
  }

 private:
  const ModelDescription& m_scene;
  double m_dx;
  LatticeCensus m_census;

  int layers_of(const BoundaryCondition& bc) const {
    return bc.mirror ? mirror_layers(m_scene.discretization.horizon_factor) : bc.layers;
  }
  int lattice_floor(double x, int axis) const {
    return static_cast<int>(std::floor((x - m_scene.discretization.origin[axis]) / m_dx - 0.5));
  }
  Vec2 lattice_point(int i, int j) const { return m_census.position(i, j); }
  CensusPoint& at(int i, int j) { return m_census.point[m_census.linear(i, j)]; }

  /// The index of the body a condition names (the parser has checked that it exists).
  int body_of(const BoundaryCondition& bc) const {
    const auto it = std::find_if(m_scene.bodies.begin(), m_scene.bodies.end(),
                                 [&](const Body& b) { return b.name == bc.body; });
    return static_cast<int>(it - m_scene.bodies.begin());
  }

  void add_body(int b) {
    const Body& body = m_scene.bodies[b];
    const Box box = polygon_box(body.shape);
    std::int64_t count = 0;
    for (int i = lattice_floor(box.lo.x(), 0); i <= lattice_floor(box.hi.x(), 0) + 1; ++i) {
      for (int j = lattice_floor(box.lo.y(), 1); j <= lattice_floor(box.hi.y(), 1) + 1; ++j) {
        if (!inside_polygon(body.shape, lattice_point(i, j))) continue;
        CensusPoint& p = at(i, j);
        if (p.exists()) {
          throw InputError(body.where, "body '" + body.name + "' overlaps body '" +
                                           m_scene.bodies[m_census.body(p)].name +
                                           "' (they share the lattice point at " +
                                           format_point(lattice_point(i, j)) + ")");
        }
        p.group = static_cast<std::uint16_t>(b + 1);
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

  /// The point (i, j) as a fictitious particle of condition k's body, created (in group
  /// n_bodies + k + 1) if absent. Throws when the point belongs to something else.
  std::size_t fictitious_at(int k, int i, int j) {
    const BoundaryCondition& bc = m_scene.boundary[k];
    CensusPoint& p = at(i, j);
    const int body = m_census.group_body[m_census.n_bodies + k + 1];
    if (!p.exists())
      p.group = static_cast<std::uint16_t>(m_census.n_bodies + k + 1);
    else if (!(m_census.body(p) == body && m_census.fictitious(p)))
      throw InputError(bc.where, "the fictitious layers of this condition overlap body '" +
                                     m_scene.bodies[m_census.body(p)].name + "' at " +
                                     format_point(lattice_point(i, j)));
    return m_census.linear(i, j);
  }

  /// Calls visit(point) for each particle condition k selects (its fictitious ones created),
  /// in the order of their numbers; returns how many.
  template <class Visit>
  std::int64_t select(int k, Visit visit) {
    const BoundaryCondition& bc = m_scene.boundary[k];
    const int body = m_census.group_body[m_census.n_bodies + k + 1];
    std::int64_t count = 0;
    const auto take = [&](std::size_t q) {
      visit(q);
      ++count;
    };
    const double eps = 1e-9 * m_dx;
    const auto in_box = [&](const Vec2& x) {  // selectors region and block
      return (x.array() >= bc.lo.array() - eps).all() && (x.array() <= bc.hi.array() + eps).all();
    };
    if (bc.selector == BoundaryCondition::Selector::region) {
      for_body_points(body, [&](int i, int j) {
        if (in_box(lattice_point(i, j))) take(m_census.linear(i, j));
      });
    } else if (bc.selector == BoundaryCondition::Selector::block) {
      // Lattice points inside the box; those of a body are not fictitious and are refused
      // by fictitious_at with a message naming the body.
      for (int i = lattice_floor(bc.lo.x() - eps, 0); i <= lattice_floor(bc.hi.x() + eps, 0) + 1; ++i)
        for (int j = lattice_floor(bc.lo.y() - eps, 1); j <= lattice_floor(bc.hi.y() + eps, 1) + 1; ++j)
          if (in_box(lattice_point(i, j))) take(fictitious_at(k, i, j));
    } else {
      select_edge(k, body, eps, take);
    }
    return count;
  }

  /// Calls f(i, j) for each of the body's own particles, in the order of their numbers.
  template <class F>
  void for_body_points(int body, F f) const {
    const Box box = polygon_box(m_scene.bodies[body].shape);
    const int ia = std::max(m_census.i0, lattice_floor(box.lo.x(), 0)),
              ib = std::min(m_census.i0 + m_census.ni - 1, lattice_floor(box.hi.x(), 0) + 1);
    const int ja = std::max(m_census.j0, lattice_floor(box.lo.y(), 1)),
              jb = std::min(m_census.j0 + m_census.nj - 1, lattice_floor(box.hi.y(), 1) + 1);
    for (int i = ia; i <= ib; ++i)
      for (int j = ja; j <= jb; ++j)
        if (m_census.at(i, j).group == body + 1) f(i, j);
  }

  /// The particles of an edge or surround condition: the body's own outermost (layers 0) or
  /// the fictitious layers outside (created as needed); `eps` the lattice tolerance.
  template <class Take>
  void select_edge(int k, int body, double eps, Take take) {
    const BoundaryCondition& bc = m_scene.boundary[k];
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
      for_body_points(body, [&](int i, int j) {
        const Vec2 x = lattice_point(i, j);
        bool chosen = false;
        if (bc.selector == BoundaryCondition::Selector::edge) {
          const double d = -outward.dot(x - a);
          chosen = d > -eps && d <= m_dx + eps && along_edge(x);
        } else {
          chosen = distance_to_boundary(shape, x) <= m_dx + eps;
        }
        if (chosen) take(m_census.linear(i, j));
      });
      return;
    }
    const double depth = layers_of(bc) * m_dx;
    const Box box = polygon_box(shape);
    for (int i = lattice_floor(box.lo.x() - depth, 0) - 1; i <= lattice_floor(box.hi.x() + depth, 0) + 1; ++i) {
      for (int j = lattice_floor(box.lo.y() - depth, 1) - 1; j <= lattice_floor(box.hi.y() + depth, 1) + 1;
           ++j) {
        const Vec2 x = lattice_point(i, j);
        if (inside_polygon(shape, x)) continue;
        bool chosen = false;
        if (bc.selector == BoundaryCondition::Selector::edge) {
          const double d = outward.dot(x - a);
          chosen = d > 0.0 && d <= depth + eps && along_edge(x);
        } else {
          chosen = distance_to_boundary(shape, x) <= depth + eps;
        }
        if (chosen) take(fictitious_at(k, i, j));
      }
    }
  }

  /// Condition k's components on the particles it selects: each prescribed once.
  void apply_condition(int k) {
    const BoundaryCondition& bc = m_scene.boundary[k];
    if (bc.mirror) {
      apply_mirror(k);
      return;
    }
    select(k, [&](std::size_t q) {
      CensusPoint& p = m_census.point[q];
      for (int comp = 0; comp < 2; ++comp) {
        const std::optional<AffineValue>& v = comp == 0 ? bc.ux : bc.uy;
        if (!v) continue;
        if (p.prescribed_by[comp] != 0) {
          throw InputError(bc.where, std::string("prescribes u") + (comp == 0 ? "x" : "y") +
                                         " of the particle at " + format_point(position_of(q)) + ", which " +
                                         m_scene.boundary[p.prescribed_by[comp] - 1].where.key +
                                         " already prescribes");
        }
        p.prescribed_by[comp] = static_cast<std::uint16_t>(k + 1);
      }
    });
  }

  Vec2 position_of(std::size_t q) const {
    const auto nj = static_cast<std::size_t>(m_census.nj);
    return lattice_point(m_census.i0 + static_cast<int>(q / nj), m_census.j0 + static_cast<int>(q % nj));
  }

  /// A mirror condition: every ghost reflects a real particle of its body across the edge
  /// line (docs/theory/osb.md, section 7); both its components are the condition's.
  void apply_mirror(int k) {
    const BoundaryCondition& bc = m_scene.boundary[k];
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
      throw InputError(bc.where, std::string("a mirror on edge ") + bc.edge_name +
                                     " prescribes only the normal component " + normal +
                                     " (the platen's displacement); " + tangential + " is the reflected body's own");
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
                                     (axis == 0 ? "x" : "y") + " = " + std::to_string(a[axis]) + " is " +
                                     std::to_string(line) + " spacings from discretization.origin, not a whole number");
    m_census.mirror_axis[k] = axis;
    m_census.mirror_line[k] = line_index;
    select(k, [&](std::size_t q) {
      const auto nj = static_cast<std::size_t>(m_census.nj);
      std::array<int, 2> l{m_census.i0 + static_cast<int>(q / nj), m_census.j0 + static_cast<int>(q % nj)};
      CensusPoint& ghost = m_census.point[q];
      l[axis] = static_cast<int>(2 * line_index - l[axis] - 1);
      const CensusPoint source = m_census.at(l[0], l[1]);
      if (!source.exists() || m_census.fictitious(source) || m_census.body(source) != m_census.body(ghost))
        throw InputError(bc.where, "the body is thinner than two horizons across edge " + bc.edge_name +
                                       ": the mirror image of " + format_point(position_of(q)) +
                                       " is not a particle of body '" + bc.body + "'");
      for (int comp = 0; comp < 2; ++comp) {
        if (ghost.prescribed_by[comp] != 0)
          throw InputError(bc.where, "the mirror layers overlap the particles that " +
                                         m_scene.boundary[ghost.prescribed_by[comp] - 1].where.key + " prescribes");
        ghost.prescribed_by[comp] = static_cast<std::uint16_t>(k + 1);
      }
    });
  }

  /// The per-group counts of particles and free components.
  void count_groups() {
    LatticeCensus& c = m_census;
    const std::size_t groups = c.group_body.size();
    c.group_particles.assign(groups, 0);
    c.group_free.assign(groups, 0);
    c.group_bonds.assign(groups, 0);
    for (const CensusPoint& p : c.point) {
      if (!p.exists()) continue;
      ++c.group_particles[p.group];
      c.group_free[p.group] += p.free_components();
    }
  }

  /// Each particle's family size (bonds within the stencil, to the same body, not cut by a
  /// pre-crack: discretise()'s) and the cut pairs.
  void count_families() {
    LatticeCensus& c = m_census;
    const double reach = m_scene.discretization.horizon_factor * m_dx + m_dx;
    std::int64_t cut = 0;
    std::vector<const Crack*> near;
    for (int i = c.i0; i < c.i0 + c.ni; ++i) {
      for (int j = c.j0; j < c.j0 + c.nj; ++j) {
        CensusPoint& p = c.point[c.linear(i, j)];
        if (!p.exists()) continue;
        const Vec2 x = lattice_point(i, j);
        near.clear();
        for (const Crack& crack : m_scene.cracks) {
          const Vec2 lo = crack.a.cwiseMin(crack.b).array() - reach;
          const Vec2 hi = crack.a.cwiseMax(crack.b).array() + reach;
          if ((x.array() >= lo.array()).all() && (x.array() <= hi.array()).all()) near.push_back(&crack);
        }
        int family = 0;
        for (const auto& o : c.stencil.offset) {
          const CensusPoint q = c.at(i + o[0], j + o[1]);
          if (!q.exists() || c.body(q) != c.body(p)) continue;
          const Vec2 y = lattice_point(i + o[0], j + o[1]);
          if (std::any_of(near.begin(), near.end(),
                          [&](const Crack* k) { return bond_crosses_crack(x, y, k->a, k->b); })) {
            ++cut;
            continue;
          }
          ++family;
        }
        p.family = static_cast<std::uint16_t>(family);
        c.group_bonds[p.group] += family;
      }
    }
    c.n_cut_bonds = cut / 2;  // each pair from both ends (bond_crosses_crack is symmetric)
    c.families_counted = true;
  }
};

}  // namespace

bool LatticeCensus::source_of(int i, int j, std::array<int, 2>& source) const {
  const CensusPoint p = at(i, j);
  if (!p.exists() || p.prescribed_by[0] == 0) return false;
  const int k = p.prescribed_by[0] - 1;
  const int axis = mirror_axis[static_cast<std::size_t>(k)];
  if (axis < 0) return false;
  source = {i, j};
  source[static_cast<std::size_t>(axis)] =
      static_cast<int>(2 * mirror_line[static_cast<std::size_t>(k)] - source[static_cast<std::size_t>(axis)] - 1);
  return true;
}

std::int64_t LatticeCensus::n_particles() const {
  std::int64_t n = 0;
  for (const std::int64_t c : group_particles) n += c;
  return n;
}

std::int64_t LatticeCensus::n_unknowns() const {
  std::int64_t n = 0;
  for (const std::int64_t c : group_free) n += c;
  return n;
}

std::int64_t LatticeCensus::n_bonds() const {
  std::int64_t n = 0;
  for (const std::int64_t c : group_bonds) n += c;
  return n;
}

LatticeCensus take_census(const ModelDescription& scene, bool count_families) {
  return CensusBuilder(scene).build(count_families);
}

}  // namespace peristat
