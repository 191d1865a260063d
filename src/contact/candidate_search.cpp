#include "contact/candidate_search.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <unordered_map>
#include <unordered_set>
#include <utility>

#include "core/error.hpp"
#include "core/geometry.hpp"

namespace peristat {

/// Large sliding: the faces are searched again for partners once a pair has slid by this
/// many spacings since the last search (section 10).
constexpr double kSearchSlide = 0.5;
/// Pairs nearly parallel to their interface (|X.n| below this many spacings) are skipped:
/// the paper law divides by X.n.
constexpr double kMinGap = 0.2;

namespace {

using Segment = CandidateSearch::Segment;

/// The cell R wide holding point x, and its key in a hash grid (partner searches).
std::pair<std::int64_t, std::int64_t> grid_cell(const Vec2& x, double R) {
  return {static_cast<std::int64_t>(std::floor(x.x() / R)), static_cast<std::int64_t>(std::floor(x.y() / R))};
}
std::uint64_t cell_key(std::int64_t cx, std::int64_t cy) {
  return (static_cast<std::uint64_t>(cx) << 32) ^ (static_cast<std::uint64_t>(cy) & 0xffffffffull);
}
/// Calls visit(entry) for every entry of a hash grid (cells R wide, by cell_key) in the 3 x 3
/// cells around x's: among them every entry within R of x.
template <class Entry, class Visit>
void visit_near(const std::unordered_map<std::uint64_t, std::vector<Entry>>& grid, const Vec2& x, double R,
                Visit&& visit) {
  const auto [cx, cy] = grid_cell(x, R);
  for (std::int64_t dx = -1; dx <= 1; ++dx)
    for (std::int64_t dy = -1; dy <= 1; ++dy) {
      const auto it = grid.find(cell_key(cx + dx, cy + dy));
      if (it == grid.end()) continue;
      for (const Entry& e : it->second) visit(e);
    }
}

/// The boundary segments shared by polygons A and B (collinear, overlapping edges).
std::vector<Segment> shared_segments(const Polygon& A, const Polygon& B, double tol) {
  std::vector<Segment> out;
  const auto& va = A.vertices;
  const auto& vb = B.vertices;
  for (std::size_t k = 0; k < va.size(); ++k) {
    const Vec2 p0 = va[k], p1 = va[(k + 1) % va.size()];
    const Vec2 d = p1 - p0;
    const double len = d.norm();
    const Vec2 e = d / len, outward(e.y(), -e.x());  // counter-clockwise polygon
    for (std::size_t m = 0; m < vb.size(); ++m) {
      const Vec2 q0 = vb[m], q1 = vb[(m + 1) % vb.size()];
      if (std::abs(outward.dot(q0 - p0)) > tol || std::abs(outward.dot(q1 - p0)) > tol) continue;
      const double s0 = std::max(0.0, std::min(e.dot(q0 - p0), e.dot(q1 - p0)));
      const double s1 = std::min(len, std::max(e.dot(q0 - p0), e.dot(q1 - p0)));
      if (s1 - s0 > tol) out.push_back({p0 + s0 * e, p0 + s1 * e, outward});
    }
  }
  return out;
}

/// Calls visit(j) for every real bond partner j > i of particle i (the stencil's offsets).
template <class Visit>
void for_partners(const Model& model, Index i, Visit&& visit) {
  const Particles& p = model.particles;
  for (const auto& off : model.stencil.offset) {
    const Index j = model.lattice_index.at(p.lattice[i][0] + off[0], p.lattice[i][1] + off[1]);
    if (j > i && !p.fictitious[j]) visit(j);
  }
}

}  // namespace

CandidateSearch::CandidateSearch(const Model& model, const ContactLaw& law, const ContactIds& ids,
                                 const PairStiffness& stiffness)
    : m_model(model), m_ids(ids), m_stiffness(stiffness) {
  const double dx = model.spacing;
  // Exact enforcement needs the pairs whose cells face each other, one spacing across.
  m_band = (law.exact ? std::max(law.radius, dx) : law.radius) * (1.0 + kLatticeRoundOff);
  m_search_radius = model.horizon + dx;
  m_search_slide = kSearchSlide * dx;
}

std::optional<ContactPair> CandidateSearch::make_pair(Index i, Index j, const Vec2& normal) const {
  if (m_ids.gid(j) < m_ids.gid(i)) std::swap(i, j);   // the whole model's orientation (on a part: by global id)
  if (!m_ids.counted(i) && !m_ids.counted(j)) return {};  // a part's pairs touch its own particles
  const Particles& p = m_model.particles;
  const Vec2 X = p.position[j] - p.position[i];
  const double proj = normal.dot(X);
  if (std::abs(proj) < kMinGap * m_model.spacing) return {};  // nearly parallel to the interface
  ContactPair c;
  c.i = i;
  c.j = j;
  c.normal = proj > 0.0 ? normal : Vec2(-normal);
  c.gap0 = std::abs(proj);
  c.stiffness = m_stiffness(i, j);
  return c;
}

std::vector<ContactPair> CandidateSearch::find_reference_pairs(const ContactOptions& options) {
  std::vector<ContactPair> pairs;
  if (options.cracks) add_crack_faces(pairs);
  for (const ContactInterface& itf : options.interfaces) add_interface(itf, pairs);
  std::sort(pairs.begin(), pairs.end(), [this](const ContactPair& x, const ContactPair& y) {
    return std::pair(m_ids.gid(x.i), m_ids.gid(x.j)) < std::pair(m_ids.gid(y.i), m_ids.gid(y.j));
  });
  pairs.erase(std::unique(pairs.begin(), pairs.end(),
                          [](const ContactPair& x, const ContactPair& y) { return x.i == y.i && x.j == y.j; }),
              pairs.end());
  if (!m_surfaces.empty()) m_u_search = VectorXd::Zero(2 * m_model.particles.size());
  return pairs;
}

void CandidateSearch::add_crack_faces(std::vector<ContactPair>& out) {
  // Crack faces: the bonds cut by a pre-crack, both ends within delta_c of that crack.
  const Particles& p = m_model.particles;
  const Index n = p.size();
  const double band = m_band;
  for (const Crack& crack : m_model.cracks) {  // the two faces, for later searches
    const Vec2 d = (crack.b - crack.a).normalized();
    const Vec2 normal(-d.y(), d.x());
    Surface surface;
    surface.crack = true;
    surface.segments.push_back({crack.a, crack.b, normal});
    for (Index i = 0; i < n; ++i) {
      if (p.fictitious[i] || geometry::distance_to_segment(p.position[i], crack.a, crack.b) > band) continue;
      (normal.dot(p.position[i] - crack.a) < 0.0 ? surface.side_a : surface.side_b).push_back(i);
    }
    m_surfaces.push_back(std::move(surface));
  }
  for (Index i = 0; i < n; ++i) {
    if (p.fictitious[i]) continue;
    for (const Crack& crack : m_model.cracks) {
      if (geometry::distance_to_segment(p.position[i], crack.a, crack.b) > band) continue;
      const Vec2 d = (crack.b - crack.a).normalized();
      const Vec2 normal(-d.y(), d.x());
      for_partners(m_model, i, [&](Index j) {
        if (p.body[j] != p.body[i] || geometry::distance_to_segment(p.position[j], crack.a, crack.b) > band)
          return;
        if (bond_crosses_crack(p.position[i], p.position[j], crack.a, crack.b))
          if (const auto c = make_pair(i, j, normal)) out.push_back(*c);
      });
    }
  }
}

void CandidateSearch::add_interface(const ContactInterface& itf, std::vector<ContactPair>& out) {
  // Declared interfaces: particles of the two bodies, both within delta_c of a shared segment.
  const Particles& p = m_model.particles;
  const Index n = p.size();
  const double band = m_band;
  int a = -1, b = -1;
  for (std::size_t k = 0; k < m_model.bodies.size(); ++k) {
    if (m_model.bodies[k].name == itf.body_a) a = static_cast<int>(k);
    if (m_model.bodies[k].name == itf.body_b) b = static_cast<int>(k);
  }
  PERISTAT_ASSERT(a >= 0 && b >= 0);
  double extent = 0.0;
  for (const Vec2& v : m_model.bodies[a].shape.vertices) extent = std::max(extent, v.cwiseAbs().maxCoeff());
  const std::vector<Segment> segments = shared_segments(m_model.bodies[a].shape, m_model.bodies[b].shape,
                                                        kLatticeRoundOff * std::max(extent, m_model.spacing));
  if (segments.empty()) {
    throw InputError(itf.where, "bodies '" + itf.body_a + "' and '" + itf.body_b +
                                    "' share no boundary segment: an interface needs a common edge");
  }
  auto nearest = [&](const Vec2& x, double& dist) -> const Segment& {
    std::size_t best = 0;
    dist = std::numeric_limits<double>::max();
    for (std::size_t k = 0; k < segments.size(); ++k) {
      const double d = geometry::distance_to_segment(x, segments[k].a, segments[k].b);
      if (d < dist) {
        dist = d;
        best = k;
      }
    }
    return segments[best];
  };
  Surface surface;
  surface.segments = segments;
  for (Index i = 0; i < n; ++i) {
    if (p.fictitious[i] || (p.body[i] != a && p.body[i] != b)) continue;
    double di = 0.0;
    nearest(p.position[i], di);
    if (di > band) continue;
    (p.body[i] == a ? surface.side_a : surface.side_b).push_back(i);
    for_partners(m_model, i, [&](Index j) {
      if (p.body[j] == p.body[i] || (p.body[j] != a && p.body[j] != b)) return;
      double dj = 0.0;
      nearest(p.position[j], dj);
      if (dj > band) return;
      double dm = 0.0;
      if (const auto c = make_pair(i, j, nearest(0.5 * (p.position[i] + p.position[j]), dm).normal))
        out.push_back(*c);
    });
  }
  m_surfaces.push_back(std::move(surface));
}

Vec2 CandidateSearch::current(Index q, const VectorXd& u) const {
  const Particles& p = m_model.particles;
  return Vec2(p.position[q].x() + u[2 * q], p.position[q].y() + u[2 * q + 1]);
}

std::vector<ContactPair> CandidateSearch::find_partners(const std::vector<ContactPair>& known_pairs,
                                                        const VectorXd& u) {
  const Particles& p = m_model.particles;
  const Index n = p.size();
  const double R = m_search_radius;
  std::unordered_set<std::uint64_t> known;
  known.reserve(2 * known_pairs.size());
  const auto key = [n](Index i, Index j) { return static_cast<std::uint64_t>(i) * n + j; };
  for (const ContactPair& c : known_pairs) known.insert(key(c.i, c.j));
  std::vector<ContactPair> found;
  for (const Surface& surface : m_surfaces) {
    // Side b in a grid of cells R wide over its current positions.
    std::unordered_map<std::uint64_t, std::vector<Index>> grid;
    for (Index j : surface.side_b) {
      const auto [cx, cy] = grid_cell(current(j, u), R);
      grid[cell_key(cx, cy)].push_back(j);
    }
    for (Index i : surface.side_a) {
      const Vec2 xi = current(i, u);
      visit_near(grid, xi, R, [&](Index j) {
        if ((current(j, u) - xi).norm() >= R) return;
        const Index lo = m_ids.gid(i) < m_ids.gid(j) ? i : j, hi = lo == i ? j : i;
        if (!m_ids.counted(lo) && !m_ids.counted(hi)) return;  // a part's pairs touch its own particles
        if (known.count(key(lo, hi))) return;
        const Vec2 &Xi = p.position[lo], &Xj = p.position[hi];
        if (surface.crack) {
          // Faces of one body: a pair within a horizon is bonded unless the crack cuts it.
          if (p.body[lo] != p.body[hi]) return;
          if ((Xj - Xi).norm() <= m_model.horizon * (1.0 + kLatticeRoundOff) &&
              !bond_crosses_crack(Xi, Xj, surface.segments[0].a, surface.segments[0].b))
            return;
        }
        double best = std::numeric_limits<double>::max();
        Vec2 normal = surface.segments[0].normal;
        for (const Segment& seg : surface.segments)
          if (const double d = geometry::distance_to_segment(0.5 * (Xi + Xj), seg.a, seg.b); d < best) {
            best = d;
            normal = seg.normal;
          }
        if (const auto c = make_pair(lo, hi, normal)) {
          found.push_back(*c);
          known.insert(key(lo, hi));
        }
      });
    }
  }
  m_u_search = u;
  ++m_searches;
  return found;
}

double CandidateSearch::slide(const ContactPair& c, const VectorXd& u) const {
  const Vec2 d(u[2 * c.j] - m_u_search[2 * c.j] - u[2 * c.i] + m_u_search[2 * c.i],
               u[2 * c.j + 1] - m_u_search[2 * c.j + 1] - u[2 * c.i + 1] + m_u_search[2 * c.i + 1]);
  return std::abs(c.tangent().dot(d));
}

double CandidateSearch::max_slide_between_searches() const {
  return m_search_radius - std::sqrt(2.0) * m_model.spacing - m_search_slide;
}

std::vector<std::int64_t> CandidateSearch::partners_not_held(const VectorXd& u, double reach) const {
  if (m_ids.holds_every_particle() || m_surfaces.empty()) return {};
  // Every rank's own face particles: (surface, side, global id, current x, y).
  struct Face {
    std::int64_t surface, side, gid;
    double x, y;
  };
  std::vector<Face> mine;
  for (std::size_t s = 0; s < m_surfaces.size(); ++s)
    for (int side = 0; side < 2; ++side)
      for (const Index q : side == 0 ? m_surfaces[s].side_a : m_surfaces[s].side_b)
        if (m_ids.counted(q)) {
          const Vec2 x = current(q, u);
          mine.push_back({static_cast<std::int64_t>(s), side, m_ids.gid(q), x.x(), x.y()});
        }
  const std::vector<Face> all = m_ids.gather(mine);
  std::vector<std::int64_t> missing;
  for (std::size_t s = 0; s < m_surfaces.size(); ++s)
    for (int side = 0; side < 2; ++side) {
      // The other side's particles, every rank's, in cells `reach` wide.
      std::unordered_map<std::uint64_t, std::vector<std::size_t>> grid;
      for (std::size_t at = 0; at < all.size(); ++at)
        if (all[at].surface == static_cast<std::int64_t>(s) && all[at].side != side) {
          const auto [cx, cy] = grid_cell(Vec2(all[at].x, all[at].y), reach);
          grid[cell_key(cx, cy)].push_back(at);
        }
      for (const Index q : side == 0 ? m_surfaces[s].side_a : m_surfaces[s].side_b) {
        if (!m_ids.counted(q)) continue;
        const Vec2 x = current(q, u);
        visit_near(grid, x, reach, [&](std::size_t at) {
          if ((Vec2(all[at].x, all[at].y) - x).norm() < reach && m_ids.local_of(all[at].gid) < 0)
            missing.push_back(all[at].gid);
        });
      }
    }
  std::sort(missing.begin(), missing.end());
  missing.erase(std::unique(missing.begin(), missing.end()), missing.end());
  return missing;
}

void CandidateSearch::save(StateArchive& archive) const {
  if (m_surfaces.empty()) return;
  // The displacement of the last search from the particles' owners (rows by global id).
  std::vector<std::int64_t> ids;
  std::vector<double> values;
  for (Index q = 0; q < m_model.particles.size(); ++q)
    if (m_ids.counted(q)) {
      ids.push_back(m_ids.gid(q));
      values.insert(values.end(), {m_u_search[2 * q], m_u_search[2 * q + 1]});
    }
  archive.put("contact/u_search", m_ids.gather_on_root(ids, values, 2, m_ids.n_particles_whole()));
  archive.put("contact/searches", m_searches);
}

void CandidateSearch::restore(const StateArchive& archive) {
  if (m_surfaces.empty()) return;
  const Index n = m_model.particles.size();
  const std::vector<double>& u = archive.get("contact/u_search", 2 * m_ids.n_particles_whole());
  m_u_search.resize(2 * n);
  for (Index q = 0; q < n; ++q)
    for (int d = 0; d < 2; ++d) m_u_search[2 * q + d] = u[static_cast<std::size_t>(2 * m_ids.gid(q) + d)];
  m_searches = static_cast<int>(archive.scalar("contact/searches"));
}

}  // namespace peristat
