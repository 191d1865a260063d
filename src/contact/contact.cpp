#include "contact/contact.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <unordered_map>
#include <unordered_set>

#include "core/error.hpp"
#include "core/geometry.hpp"

namespace peristat {

/// Relative margin for distances computed from lattice coordinates (a partner exactly at
/// the contact radius or on the interface line counts).
constexpr double kLatticeRoundOff = 1e-9;
/// A pair Jacobian is symmetric when its off-diagonal entries agree to this fraction of its
/// largest entry (round-off of n n^T and t t^T products).
constexpr double kSymmetryTolerance = 1e-12;
/// Exact enforcement: an update that leaves a pair's closure above this fraction of its
/// previous value makes the pair's augmentation kBoost times stiffer, up to
/// kMaxAugmentationModulus times the eq 17 modulus (the stiffness sets only the rate of the
/// multiplier iteration, not its answer).
constexpr double kAugmentationReduction = 0.25;
constexpr double kBoost = 4.0;

/// Exact enforcement: the augmentation modulus is at most this multiple of the eq 17
/// modulus. Measured on the pressed blocks (tests/verification/test_contact.cpp): 73 x
/// converges, 180 x makes Newton's line search fail on pairs entering the window; the
/// answer does not depend on it.
constexpr double kMaxAugmentationModulus = 10.0;
/// Large sliding: the faces are searched again for partners once a pair has slid by this
/// many spacings since the last search (section 10).
constexpr double kSearchSlide = 0.5;
/// Pairs nearly parallel to their interface (|X.n| below this many spacings) are skipped:
/// the paper law divides by X.n.
constexpr double kMinGap = 0.2;

/// The stiffness of a closed pair at full gate along its interface normal, (normal_scale C/a)
/// n n^T, plus k_t t t^T when it sticks: the preconditioner's block of a pair in contact and
/// the predictor's Jacobian of a touching one (normal_scale: the augmentation boost, 1 under
/// penalty, 0 when the law's normal term lies elsewhere).
static Mat2 closed_pair_block(const ContactPair& pair, double normal_scale, double tangential_factor,
                              bool stick) {
  const double kn = pair.stiffness / pair.gap0;
  Mat2 S = (normal_scale * kn) * pair.normal * pair.normal.transpose();
  if (stick) {
    const Vec2 t = pair.tangent();
    S += (tangential_factor * kn) * t * t.transpose();
  }
  return S;
}

/// ContactSystem::set_touching_closed(): an open pair that touches gets the stiffness of a
/// closed pair at full gate, stuck when the law has friction; its force stays zero.
static void close_if_touching(const ContactPair& pair, const Vec2& X, const Vec2& du, double boost,
                              const ContactLaw& law, PairResult& out) {
  const Vec2 Y = X + du;
  const double yn = pair.normal.dot(Y), s = 1.0 - yn / pair.gap0;
  const bool stick = law.friction > 0.0;
  if (law.exact) {
    if (pair.gap0 > law.window * (1.0 + kLatticeRoundOff) || std::abs(pair.tangent().dot(Y)) >= law.window ||
        s < -kLatticeRoundOff)
      return;
    out.J = closed_pair_block(pair, boost, law.tangential_factor, stick);
  } else if (law.normal == NormalLaw::paper) {
    if (yn <= 0.0 || Y.norm() > law.radius * (1.0 + kLatticeRoundOff) || s < -kLatticeRoundOff) return;
    out.J = closed_pair_block(pair, 1.0, law.tangential_factor, stick);
  } else {  // pair law: the normal term acts along the current pair direction
    const double r = Y.norm();
    if (r > law.radius * (1.0 + kLatticeRoundOff) || r <= std::numeric_limits<double>::min()) return;
    const Vec2 e = Y / r;
    out.J = (pair.stiffness / law.radius) * e * e.transpose() +
            closed_pair_block(pair, 0.0, law.tangential_factor, stick);
  }
  out.status = stick ? PairStatus::stick : PairStatus::slip;  // frictionless closed pairs slide freely
}

PairResult contact_pair(const ContactPair& pair, const Vec2& X, const Vec2& du, const PairHistory& history,
                        const ContactLaw& law, bool want_jacobian) {
  PairResult out;
  const Vec2 Y = X + du;
  const Vec2& n = pair.normal;
  const double a = pair.gap0, C = pair.stiffness;

  // Normal force F >= 0 and its gradient dF/dY.
  double F = 0.0;
  Vec2 dF = Vec2::Zero();
  Vec2 along = n;  // direction of the normal force on j
  Mat2 Jn = Mat2::Zero();
  if (law.exact) {
    // Augmented Lagrangian along n (section 8): F = phi(|t.Y|) max(0, lambda + C s), for a
    // pair whose cells face each other. No distance gate: a pair that has crossed (n.Y < 0,
    // s > 1) is pushed back harder.
    if (a > law.window * (1.0 + kLatticeRoundOff)) return out;
    const Vec2 t = pair.tangent();
    const double yt = t.dot(Y), offset = std::abs(yt);
    if (offset >= law.window) return out;
    const double s = 1.0 - n.dot(Y) / a;
    const double Ca = history.boost * C;  // the pair's augmentation stiffness
    const double q = history.multiplier + Ca * s;
    if (q <= 0.0) return out;
    double phi = 1.0;
    Vec2 dphi = Vec2::Zero();
    if (law.gate > 0.0) {
      const double width = law.gate * law.window, rho = (law.window - offset) / width;
      if (rho < 1.0) {
        phi = rho;
        dphi = -(yt > 0.0 ? 1.0 : -1.0) / width * t;
      }
    }
    F = phi * q;
    dF = -(phi * Ca / a) * n + q * dphi;
    if (want_jacobian) Jn = -n * dF.transpose();
  } else if (law.normal == NormalLaw::paper) {
    // Eq 16: stretch of the virtual bond along the interface normal, compression positive.
    // The gate distance is |Y| while the particles have not passed each other (the paper's
    // rule) and |t.Y| once they have (n.Y < 0), so that a crossed pair is pushed back, not
    // released (section 2).
    const double yn = n.dot(Y);
    const bool has_crossed = yn < 0.0;
    const double r = has_crossed ? std::abs(pair.tangent().dot(Y)) : Y.norm();
    const double rc = law.radius;
    if (r >= rc) return out;
    const double s = 1.0 - yn / a;
    if (s <= 0.0) return out;
    // Switch-on ramp h(r): 0 at delta_c, 1 from (1 - gate) delta_c inwards.
    double h = 1.0;
    Vec2 dh = Vec2::Zero();
    if (law.gate > 0.0) {
      const double width = law.gate * rc, rho = (rc - r) / width;
      if (rho < 1.0) {
        h = rho;
        if (has_crossed) {
          const Vec2 t = pair.tangent();
          dh = -(t.dot(Y) > 0.0 ? 1.0 : -1.0) / width * t;
        } else {
          dh = -Y / (r * width);
        }
      }
    }
    F = C * s * h;
    dF = C * (-h / a * n + s * dh);
    if (want_jacobian) Jn = -n * dF.transpose();
  } else {
    // Pair law: along the current pair direction, zero at delta_c.
    const double r = Y.norm();
    const double rc = law.radius;
    if (r >= rc) return out;
    if (r <= std::numeric_limits<double>::min()) return out;
    const Vec2 e = Y / r;
    F = C * (rc - r) / rc;
    dF = -C / rc * e;
    along = e;
    if (want_jacobian) Jn = (C / rc) * e * e.transpose() - (F / r) * (Mat2::Identity() - e * e.transpose());
  }
  if (F <= 0.0) return out;
  out.normal_force = F;
  out.g = -F * along;
  if (want_jacobian) out.J = Jn;

  // Coulomb friction along t by a return map on w - w_p (eq 14).
  out.status = PairStatus::slip;  // frictionless pairs slide freely
  if (law.friction > 0.0 && law.velocity_sign) {
    // Eq 13: f_c F_n opposing the relative tangential velocity; none while it is zero.
    const Vec2 t = pair.tangent();
    const double v = history.tangential_velocity;
    const double sign = v > 0.0 ? 1.0 : (v < 0.0 ? -1.0 : 0.0);
    out.status = sign == 0.0 ? PairStatus::stick : PairStatus::slip;
    out.tangential = sign * law.friction * F;
    if (want_jacobian) out.J += (sign * law.friction) * t * dF.transpose();
    out.g += out.tangential * t;
  } else if (law.friction > 0.0) {
    const Vec2 t = pair.tangent();
    const double kt = law.tangential_factor * C / a;
    const double trial = kt * (t.dot(du) - history.slip);
    const double limit = law.friction * F;
    if (std::abs(trial) <= limit) {
      out.status = PairStatus::stick;
      out.tangential = trial;
      if (want_jacobian) out.J += kt * t * t.transpose();
    } else {
      const double sign = trial > 0.0 ? 1.0 : -1.0;
      out.tangential = sign * limit;
      if (want_jacobian) out.J += (sign * law.friction) * t * dF.transpose();
    }
    out.g += out.tangential * t;
  }
  return out;
}

namespace {

using Segment = ContactSystem::Segment;

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

/// Contact modulus of eq 17 (or the scene's override).
double contact_modulus(const Material& m1, const Material& m2, double override_value) {
  if (override_value > 0.0) return override_value;
  return 1.0 / ((1.0 - m1.nu * m1.nu) / m1.E + (1.0 - m2.nu * m2.nu) / m2.E);
}

}  // namespace

ContactSystem::ContactSystem(const Model& model, const ContactOptions& o, ContactRanks ranks)
    : m_model(model), m_ranks(std::move(ranks)) {
  if (partitioned()) {
    if (m_ranks.global_id.size() != static_cast<std::size_t>(model.particles.size()) ||
        m_ranks.counted.size() != m_ranks.global_id.size() || !m_ranks.gather || !m_ranks.gather_on_root)
      throw std::logic_error(
          "ContactSystem: a part needs a global id and a counted flag per particle, and the gathers");
    m_by_global.reserve(m_ranks.global_id.size());
    for (std::size_t q = 0; q < m_ranks.global_id.size(); ++q)
      m_by_global.emplace_back(m_ranks.global_id[q], static_cast<Index>(q));
    std::sort(m_by_global.begin(), m_by_global.end());
  }
  const double dx = model.spacing;
  m_law.normal = o.normal;
  m_law.radius = o.radius_factor * dx;
  m_law.gate = o.gate;
  m_law.friction = o.friction;
  m_law.tangential_factor = o.tangential_factor;
  m_law.velocity_sign = o.velocity_sign && o.friction > 0.0;
  m_law.exact = o.enforcement == ContactEnforcement::exact;
  m_law.window = dx;
  m_closure_tolerance = o.closure_tolerance;
  m_max_multiplier_updates = o.max_multiplier_updates;

  const Particles& p = model.particles;
  const Index n = p.size();
  // Exact enforcement needs the pairs whose cells face each other, one spacing across.
  const double band = (m_law.exact ? std::max(m_law.radius, dx) : m_law.radius) * (1.0 + kLatticeRoundOff);
  const double min_gap = kMinGap * dx;  // pairs nearly parallel to the interface are skipped
  const double delta3 = std::pow(model.horizon, 3);
  m_modulus_override = o.stiffness;
  m_delta3 = delta3;
  auto add_pair = [&](Index i, Index j, const Vec2& normal) {
    if (gid(j) < gid(i)) std::swap(i, j);    // the whole model's orientation (on a part: by global id)
    if (!counted(i) && !counted(j)) return;  // a part's pairs touch its own particles
    const Vec2 X = p.position[j] - p.position[i];
    const double proj = normal.dot(X);
    if (std::abs(proj) < min_gap) return;
    ContactPair c;
    c.i = i;
    c.j = j;
    c.normal = proj > 0.0 ? normal : Vec2(-normal);
    c.gap0 = std::abs(proj);
    c.stiffness = pair_stiffness(i, j);
    m_pairs.push_back(c);
  };
  auto for_partners = [&](Index i, auto&& visit) {
    for (const auto& off : model.stencil.offset) {
      const Index j = model.lattice_index.at(p.lattice[i][0] + off[0], p.lattice[i][1] + off[1]);
      if (j > i && !p.fictitious[j]) visit(j);
    }
  };

  // Crack faces: the bonds cut by a pre-crack, both ends within delta_c of that crack.
  if (o.cracks) {
    for (const Crack& crack : model.cracks) {  // the two faces, for later searches
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
      for (const Crack& crack : model.cracks) {
        if (geometry::distance_to_segment(p.position[i], crack.a, crack.b) > band) continue;
        const Vec2 d = (crack.b - crack.a).normalized();
        const Vec2 normal(-d.y(), d.x());
        for_partners(i, [&](Index j) {
          if (p.body[j] != p.body[i] || geometry::distance_to_segment(p.position[j], crack.a, crack.b) > band)
            return;
          if (bond_crosses_crack(p.position[i], p.position[j], crack.a, crack.b)) add_pair(i, j, normal);
        });
      }
    }
  }

  // Declared interfaces: particles of the two bodies, both within delta_c of a shared segment.
  for (const ContactInterface& itf : o.interfaces) {
    int a = -1, b = -1;
    for (std::size_t k = 0; k < model.bodies.size(); ++k) {
      if (model.bodies[k].name == itf.body_a) a = static_cast<int>(k);
      if (model.bodies[k].name == itf.body_b) b = static_cast<int>(k);
    }
    PERISTAT_ASSERT(a >= 0 && b >= 0);
    double extent = 0.0;
    for (const Vec2& v : model.bodies[a].shape.vertices) extent = std::max(extent, v.cwiseAbs().maxCoeff());
    const std::vector<Segment> segments = shared_segments(model.bodies[a].shape, model.bodies[b].shape,
                                                          kLatticeRoundOff * std::max(extent, dx));
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
      for_partners(i, [&](Index j) {
        if (p.body[j] == p.body[i] || (p.body[j] != a && p.body[j] != b)) return;
        double dj = 0.0;
        nearest(p.position[j], dj);
        if (dj > band) return;
        double dm = 0.0;
        add_pair(i, j, nearest(0.5 * (p.position[i] + p.position[j]), dm).normal);
      });
    }
    m_surfaces.push_back(std::move(surface));
  }

  std::sort(m_pairs.begin(), m_pairs.end(), [this](const ContactPair& x, const ContactPair& y) {
    return std::pair(gid(x.i), gid(x.j)) < std::pair(gid(y.i), gid(y.j));
  });
  m_pairs.erase(
      std::unique(m_pairs.begin(), m_pairs.end(),
                  [](const ContactPair& x, const ContactPair& y) { return x.i == y.i && x.j == y.j; }),
      m_pairs.end());
  const Index np = size();
  m_result.assign(np, PairResult{});
  if (tracks_slip()) m_slip.assign(np, 0.0);
  if (m_law.velocity_sign) m_tangential_velocity.assign(np, 0.0);
  if (m_law.exact) {
    m_multiplier.assign(np, 0.0);
    m_multiplier_committed.assign(np, 0.0);
    m_boost.resize(np);
    m_last_violation.assign(np, 0.0);
    m_boost_limit.resize(np);
    for (Index k = 0; k < np; ++k) {
      m_boost_limit[k] = boost_limit(m_pairs[k]);
      m_boost[k] = initial_boost(m_pairs[k]);
    }
  }
  m_counts.candidates = np;
  if (partitioned()) {  // every rank's own pairs
    Index own = 0;
    for (const ContactPair& c : m_pairs) own += counted(c.i);
    const std::vector<double> all = m_ranks.gather({static_cast<double>(own)});
    m_counts.candidates = 0;
    for (const double v : all) m_counts.candidates += static_cast<Index>(v);
  }
  m_counts.open = m_counts.candidates;
  if (m_law.exact) m_augmentation_capped = max_over_ranks(m_augmentation_capped ? 1.0 : 0.0) > 0.0;
  m_round_start = np;
  m_search_radius = model.horizon + dx;
  m_search_slide = kSearchSlide * dx;
  if (!m_surfaces.empty()) m_u_search = VectorXd::Zero(2 * n);
  build_incidence();
}

double ContactSystem::pair_stiffness(Index i, Index j, double modulus_override) const {
  const Particles& p = m_model.particles;
  const Material &mi = m_model.bodies[p.body[i]].material, &mj = m_model.bodies[p.body[j]].material;
  const double thickness = 0.5 * (mi.thickness + mj.thickness);
  return 3.0 * contact_modulus(mi, mj, modulus_override) * p.volume[i] * p.volume[j] / (m_delta3 * thickness);
}

double ContactSystem::pair_stiffness(Index i, Index j) {
  // Exact enforcement: C is the eq 17 pair stiffness, which sets the stick penalty k_t;
  // contact.stiffness only sets where the augmentation starts (initial_boost), so that it
  // changes the rate of the multiplier iteration and not the answer.
  return pair_stiffness(i, j, m_law.exact ? 0.0 : m_modulus_override);
}

double ContactSystem::boost_limit(const ContactPair& c) const {
  return kMaxAugmentationModulus * pair_stiffness(c.i, c.j, 0.0) / c.stiffness;
}

double ContactSystem::initial_boost(const ContactPair& c) {
  // The augmentation modulus sets the rate only: by default the cap, which converges in the
  // fewest updates; contact.stiffness when the scene gives one, but never above the cap (a
  // stiffer augmentation stalls Newton).
  const double limit = boost_limit(c);
  if (m_modulus_override <= 0.0) return limit;
  const double requested = pair_stiffness(c.i, c.j, m_modulus_override) / c.stiffness;
  if (requested > limit) m_augmentation_capped = true;
  return std::min(requested, limit);
}

void ContactSystem::add_broken_bonds(const std::vector<std::pair<Index, Index>>& bonds, const VectorXd& u) {
  const Particles& p = m_model.particles;
  m_round_start = size();
  for (const auto& [a, b] : bonds) {
    const Index i = gid(a) < gid(b) ? a : b, j = i == a ? b : a;
    if (p.fictitious[i] || p.fictitious[j]) continue;
    if (!counted(i) && !counted(j)) continue;  // a part holds the pairs that touch its own particles
    const Vec2 X = p.position[j] - p.position[i];
    ContactPair c;
    c.i = i;
    c.j = j;
    c.normal = X.normalized();  // a broken bond's faces meet along the bond
    c.gap0 = X.norm();
    c.stiffness = pair_stiffness(i, j);
    append_state(c, u);  // no stored tangential force: like a pair that was open
    m_pairs.push_back(c);
  }
  m_counts.candidates = size();
  build_incidence();
}

void ContactSystem::drop_last_round() {
  if (m_round_start == size()) return;  // the round added no pair
  const auto n = static_cast<std::size_t>(m_round_start);
  m_pairs.resize(n);
  m_result.resize(n);
  if (tracks_slip()) m_slip.resize(n);
  if (m_law.velocity_sign) m_tangential_velocity.resize(n);
  if (m_law.exact) {
    m_multiplier.resize(n);
    m_multiplier_committed.resize(n);
    m_boost.resize(n);
    m_last_violation.resize(n);
    m_boost_limit.resize(n);
  }
  m_counts.candidates = size();
  build_incidence();
}

void ContactSystem::build_incidence() {
  const Index n = m_model.particles.size();
  const Index np = size();
  // Incidence CSR: the pairs of each particle.
  m_incident_start.assign(n + 1, 0);
  for (const ContactPair& c : m_pairs) {
    ++m_incident_start[c.i + 1];
    ++m_incident_start[c.j + 1];
  }
  for (Index q = 0; q < n; ++q) m_incident_start[q + 1] += m_incident_start[q];
  m_incident.resize(m_incident_start[n]);
  std::vector<Index> fill(m_incident_start.begin(), m_incident_start.end() - 1);
  for (Index k = 0; k < np; ++k) {
    m_incident[fill[m_pairs[k].i]++] = {k, m_pairs[k].j, -1};
    m_incident[fill[m_pairs[k].j]++] = {k, m_pairs[k].i, +1};
  }
}

void ContactSystem::evaluate(const VectorXd& u, bool want_jacobian) {
  const Particles& p = m_model.particles;
  const Index np = size();
  const bool friction = tracks_slip();
#pragma omp parallel for schedule(static)
  for (Index k = 0; k < np; ++k) {
    const ContactPair& c = m_pairs[k];
    if (excluded(c)) {
      m_result[k] = PairResult{};
      continue;
    }
    const Vec2 du(u[2 * c.j] - u[2 * c.i], u[2 * c.j + 1] - u[2 * c.i + 1]);
    const PairHistory history{friction ? m_slip[k] : 0.0, m_law.exact ? m_multiplier[k] : 0.0,
                              m_law.velocity_sign ? m_tangential_velocity[k] : 0.0,
                              m_law.exact ? m_boost[k] : 1.0};
    m_result[k] = contact_pair(c, p.position[c.j] - p.position[c.i], du, history, m_law, want_jacobian);
    if (m_touching_closed && want_jacobian && m_result[k].status == PairStatus::open)
      close_if_touching(c, p.position[c.j] - p.position[c.i], du, history.boost, m_law, m_result[k]);
  }
  ContactCounts counts;
  counts.candidates = np;
  std::uint64_t hash = 1469598103934665603ull;  // FNV-1a over the statuses
  double dmin = std::numeric_limits<double>::infinity();
  double closure = 0.0;
  bool symmetric = true;
  for (Index k = 0; k < np; ++k) {
    if (!counted(m_pairs[k].i)) continue;  // on a part: another rank's pair
    const PairStatus s = m_result[k].status;
    const Mat2& J = m_result[k].J;
    symmetric = symmetric && std::abs(J(0, 1) - J(1, 0)) <= kSymmetryTolerance * J.cwiseAbs().maxCoeff();
    counts.open += s == PairStatus::open;
    counts.stick += s == PairStatus::stick;
    counts.slip += s == PairStatus::slip;
    hash = (hash ^ static_cast<std::uint64_t>(s)) * 1099511628211ull;
    const ContactPair& c = m_pairs[k];
    const Vec2 Y =
        p.position[c.j] - p.position[c.i] + Vec2(u[2 * c.j] - u[2 * c.i], u[2 * c.j + 1] - u[2 * c.i + 1]);
    dmin = std::min(dmin, Y.norm());
    if (m_result[k].normal_force > 0.0) closure = std::max(closure, c.gap0 - c.normal.dot(Y));
  }
  m_counts = counts;
  m_signature = hash;
  if (want_jacobian) m_symmetric = symmetric;  // describes the last Jacobian computed
  m_min_distance = np > 0 ? dmin : 0.0;
  m_max_closure = closure;
  if (partitioned()) reduce_over_ranks(want_jacobian);
}

void ContactSystem::reduce_over_ranks(bool want_jacobian) {
  // Each rank's figures of its own pairs; every rank combines them in rank order alike.
  Index own = 0;
  for (const ContactPair& c : m_pairs) own += counted(c.i);
  const std::uint64_t h = m_signature;
  const std::vector<double> mine = {static_cast<double>(own),
                                    static_cast<double>(m_counts.open),
                                    static_cast<double>(m_counts.stick),
                                    static_cast<double>(m_counts.slip),
                                    own > 0 ? m_min_distance : std::numeric_limits<double>::infinity(),
                                    m_max_closure,
                                    m_symmetric ? 1.0 : 0.0,
                                    static_cast<double>(h & 0xffff),
                                    static_cast<double>((h >> 16) & 0xffff),
                                    static_cast<double>((h >> 32) & 0xffff),
                                    static_cast<double>(h >> 48)};
  constexpr std::size_t width = 11;
  const std::vector<double> all = m_ranks.gather(mine);
  ContactCounts counts;
  std::uint64_t hash = 1469598103934665603ull;
  double dmin = std::numeric_limits<double>::infinity(), closure = 0.0;
  bool symmetric = true;
  for (std::size_t at = 0; at + width <= all.size(); at += width) {
    counts.candidates += static_cast<Index>(all[at]);
    counts.open += static_cast<Index>(all[at + 1]);
    counts.stick += static_cast<Index>(all[at + 2]);
    counts.slip += static_cast<Index>(all[at + 3]);
    dmin = std::min(dmin, all[at + 4]);
    closure = std::max(closure, all[at + 5]);
    symmetric = symmetric && all[at + 6] != 0.0;
    for (std::size_t q = 0; q < 4; ++q)
      hash = (hash ^ static_cast<std::uint64_t>(all[at + 7 + q])) * 1099511628211ull;
  }
  m_counts = counts;
  m_signature = hash;
  if (want_jacobian) m_symmetric = symmetric;
  m_min_distance = counts.candidates > 0 ? dmin : 0.0;
  m_max_closure = closure;
}

double ContactSystem::max_over_ranks(double value) const {
  if (!partitioned()) return value;
  double out = value;
  for (const double v : m_ranks.gather({value})) out = std::max(out, v);
  return out;
}

Index ContactSystem::local_of(std::int64_t g) const {
  const auto it =
      std::lower_bound(m_by_global.begin(), m_by_global.end(), std::pair<std::int64_t, Index>(g, -1));
  return it != m_by_global.end() && it->first == g ? it->second : -1;
}

void ContactSystem::add_internal_force(VectorXd& force) const {
  const Index n = m_model.particles.size();
#pragma omp parallel for schedule(static)
  for (Index q = 0; q < n; ++q) {
    if (!counted(q)) continue;  // on a part: another rank's particle (its rows add its pairs)
    for (const Incidence* e = incident_begin(q); e != incident_end(q); ++e) {
      const Vec2& g = m_result[e->pair].g;
      force[2 * q] += e->sign * g.x();
      force[2 * q + 1] += e->sign * g.y();
    }
  }
}

void ContactSystem::contact_force(VectorXd& out) const {
  out.setZero(2 * m_model.particles.size());
  add_internal_force(out);
  out = -out;
}

void ContactSystem::particle_states(std::vector<int>& out) const {
  out.assign(m_model.particles.size(), 0);
  for (std::size_t k = 0; k < m_pairs.size(); ++k) {
    const int s = static_cast<int>(m_result[k].status);  // open 0, stick 1, slip 2
    out[m_pairs[k].i] = std::max(out[m_pairs[k].i], s);
    out[m_pairs[k].j] = std::max(out[m_pairs[k].j], s);
  }
}

Mat2 ContactSystem::preconditioner_block(Index k) const {
  const PairResult& r = m_result[k];
  if (r.status == PairStatus::open) return Mat2::Zero();
  return closed_pair_block(m_pairs[k], m_law.exact ? m_boost[k] : 1.0, m_law.tangential_factor,
                           r.status == PairStatus::stick);
}

double ContactSystem::stiffness_bound(Index k) const {
  const ContactPair& c = m_pairs[k];
  if (m_law.exact) {  // phi C / a along n, plus the window ramp carrying lambda + C s (s <= 1)
    const double ca = m_boost[k] * c.stiffness;
    double b = ca / c.gap0;
    if (m_law.gate > 0.0) b += (multiplier(k) + ca) / (m_law.gate * m_law.window);
    if (m_law.friction > 0.0) b += m_law.tangential_factor * c.stiffness / c.gap0;
    return b;
  }
  double b = c.stiffness * (1.0 / c.gap0 + 1.0 / m_law.radius);
  if (m_law.friction > 0.0) b += m_law.tangential_factor * c.stiffness / c.gap0;
  if (m_law.normal == NormalLaw::paper && m_law.gate > 0.0) b += c.stiffness / (m_law.gate * m_law.radius);
  return b;
}

void ContactSystem::set_velocity(const VectorXd& v) {
  if (!m_law.velocity_sign) return;
  const Index np = size();
  for (Index k = 0; k < np; ++k) {
    const ContactPair& c = m_pairs[k];
    m_tangential_velocity[k] =
        c.tangent().dot(Vec2(v[2 * c.j] - v[2 * c.i], v[2 * c.j + 1] - v[2 * c.i + 1]));
  }
}

void ContactSystem::start_trial(double ratio) {
  if (!m_law.exact) return;
  const Index np = size();
  for (Index k = 0; k < np; ++k) m_multiplier[k] = ratio * m_multiplier_committed[k];
  std::fill(m_last_violation.begin(), m_last_violation.end(), 0.0);
  m_multiplier_updates = 0;
}

MultiplierUpdate ContactSystem::update_multipliers(const VectorXd& u) {
  MultiplierUpdate m;
  if (!m_law.exact) return m;
  evaluate(u, false);
  const Particles& p = m_model.particles;
  const Index np = size();
  // Facing pairs (the kernel's exact branch): within one spacing across and along.
  std::vector<double> closure(np, 0.0), violation(np, 0.0);
  std::vector<char> facing(np, 0);
  for (Index k = 0; k < np; ++k) {
    const ContactPair& c = m_pairs[k];
    const Vec2 du(u[2 * c.j] - u[2 * c.i], u[2 * c.j + 1] - u[2 * c.i + 1]);
    const PairGap g = pair_gap(c, p.position[c.j] - p.position[c.i], du);
    if (c.gap0 > m_law.window * (1.0 + kLatticeRoundOff) || std::abs(g.tangential) >= m_law.window) continue;
    facing[k] = 1;
    closure[k] = 1.0 - g.normal / c.gap0;
    violation[k] = m_result[k].normal_force > 0.0 ? std::abs(closure[k]) : std::max(0.0, closure[k]);
    if (!counted(c.i)) continue;  // on a part: another rank's pair (updated alike below)
    if (m_result[k].normal_force > 0.0) m.opening = std::max(m.opening, -closure[k]);
    if (violation[k] > m.violation) {
      m.violation = violation[k];
      m.pair_i = gid(c.i);
      m.pair_j = gid(c.j);
    }
  }
  if (partitioned()) {  // the largest over every rank's own pairs; of equals, the first in the whole model's
                        // order
    const std::vector<double> all = m_ranks.gather(
        {m.violation, m.opening, static_cast<double>(m.pair_i), static_cast<double>(m.pair_j)});
    MultiplierUpdate best;
    for (std::size_t at = 0; at + 4 <= all.size(); at += 4) {
      best.opening = std::max(best.opening, all[at + 1]);
      const auto i = static_cast<std::int64_t>(all[at + 2]), j = static_cast<std::int64_t>(all[at + 3]);
      if (all[at] > best.violation || (i >= 0 && all[at] == best.violation && best.pair_i >= 0 &&
                                       std::pair(i, j) < std::pair(best.pair_i, best.pair_j))) {
        best.violation = all[at];
        best.pair_i = i;
        best.pair_j = j;
      }
    }
    m.violation = best.violation;
    m.opening = best.opening;
    m.pair_i = best.pair_i;
    m.pair_j = best.pair_j;
  }
  m.updates = m_multiplier_updates;
  if (m.violation <= m_closure_tolerance) return m;
  if (m_multiplier_updates >= m_max_multiplier_updates) {
    m.status = MultiplierUpdate::Status::exhausted;
    return m;
  }
  // Uzawa: lambda <- max(0, lambda + C_k s). A pair whose violation above the tolerance fell
  // by less than kAugmentationReduction since the last update gets a stiffer augmentation
  // (method of multipliers, Bertsekas 1982, sec. 2.2): C_k = boost_k C, boost_k *= kBoost.
  for (Index k = 0; k < np; ++k) {
    if (!facing[k]) {
      m_multiplier[k] = 0.0;
      continue;
    }
    const double ck = m_boost[k] * m_pairs[k].stiffness;
      // A pair open beyond the tolerance lets go of its force at once (the multiplier of an
    // inactive constraint is zero); the others take the Uzawa step.
    m_multiplier[k] = closure[k] < -m_closure_tolerance ? 0.0 : std::max(0.0, m_multiplier[k] + ck * closure[k]);
    if (violation[k] > m_closure_tolerance && m_last_violation[k] > 0.0 &&
        violation[k] > kAugmentationReduction * m_last_violation[k])
      m_boost[k] = std::min(m_boost_limit[k], kBoost * m_boost[k]);
    m_last_violation[k] = violation[k];
  }
  m.updates = ++m_multiplier_updates;
  m.status = MultiplierUpdate::Status::updated;
  return m;
}

CrossedPair ContactSystem::first_crossed_pair(const VectorXd& u) const {
  const Particles& p = m_model.particles;
  CrossedPair out;
  const Index k = first_crossed(u);
  if (k >= 0) {
    const ContactPair& c = m_pairs[k];
    const Vec2 du(u[2 * c.j] - u[2 * c.i], u[2 * c.j + 1] - u[2 * c.i + 1]);
    out = {gid(c.i), gid(c.j), p.position[c.i], p.position[c.j],
           pair_gap(c, p.position[c.j] - p.position[c.i], du).normal};
  }
  if (!partitioned()) return out;
  // Every rank's first own crossed pair; the first of those in the whole model's order.
  const std::vector<double> all =
      m_ranks.gather({static_cast<double>(out.i), static_cast<double>(out.j), out.Xi.x(), out.Xi.y(),
                      out.Xj.x(), out.Xj.y(), out.normal});
  CrossedPair first;
  for (std::size_t at = 0; at + 7 <= all.size(); at += 7) {
    const auto i = static_cast<std::int64_t>(all[at]), j = static_cast<std::int64_t>(all[at + 1]);
    if (i < 0 || (first.any() && std::pair(first.i, first.j) < std::pair(i, j))) continue;
    first = {i, j, Vec2(all[at + 2], all[at + 3]), Vec2(all[at + 4], all[at + 5]), all[at + 6]};
  }
  return first;
}

std::int64_t ContactSystem::partners_outside(const VectorXd& u) const {
  if (!partitioned() || m_surfaces.empty()) return 0;
  const Particles& p = m_model.particles;
  const auto current = [&](Index q) {
    return Vec2(p.position[q].x() + u[2 * q], p.position[q].y() + u[2 * q + 1]);
  };
  // Every rank's own face particles: (surface, side, global id, current x, y).
  std::vector<double> mine;
  for (std::size_t s = 0; s < m_surfaces.size(); ++s)
    for (int side = 0; side < 2; ++side)
      for (const Index q : side == 0 ? m_surfaces[s].side_a : m_surfaces[s].side_b)
        if (counted(q)) {
          const Vec2 x = current(q);
          mine.insert(mine.end(), {static_cast<double>(s), static_cast<double>(side),
                                   static_cast<double>(gid(q)), x.x(), x.y()});
        }
  const std::vector<double> all = m_ranks.gather(mine);
  const double R = m_search_radius;
  std::int64_t outside = 0;
  for (std::size_t s = 0; s < m_surfaces.size(); ++s)
    for (int side = 0; side < 2; ++side) {
      // The other side's particles, every rank's, in cells R wide.
      std::unordered_map<std::uint64_t, std::vector<std::size_t>> grid;
      for (std::size_t at = 0; at + 5 <= all.size(); at += 5)
        if (all[at] == static_cast<double>(s) && all[at + 1] != static_cast<double>(side)) {
          const auto [cx, cy] = grid_cell(Vec2(all[at + 3], all[at + 4]), R);
          grid[cell_key(cx, cy)].push_back(at);
        }
      for (const Index q : side == 0 ? m_surfaces[s].side_a : m_surfaces[s].side_b) {
        if (!counted(q)) continue;
        const Vec2 x = current(q);
        visit_near(grid, x, R, [&](std::size_t at) {
          if ((Vec2(all[at + 3], all[at + 4]) - x).norm() < R &&
              local_of(static_cast<std::int64_t>(all[at + 2])) < 0)
            ++outside;
        });
      }
    }
  std::int64_t total = 0;
  for (const double v : m_ranks.gather({static_cast<double>(outside)})) total += static_cast<std::int64_t>(v);
  return total;
}

Index ContactSystem::first_crossed(const VectorXd& u) const {
  const Particles& p = m_model.particles;
  const Index np = size();
  for (Index k = 0; k < np; ++k) {
    const ContactPair& c = m_pairs[k];
    if (excluded(c) || !counted(c.i)) continue;  // on a part: its own pairs
    const Vec2 du(u[2 * c.j] - u[2 * c.i], u[2 * c.j + 1] - u[2 * c.i + 1]);
    if (crossed(pair_gap(c, p.position[c.j] - p.position[c.i], du), m_model.spacing)) return k;
  }
  return -1;
}

void ContactSystem::commit(const VectorXd& u) {
  m_round_start = size();
  m_multiplier_committed = m_multiplier;
  m_multiplier_updates = 0;
  evaluate(u, false);
  update_slip(u);
  // Large sliding: partners are searched again in the current configuration once the faces
  // have slid by kSearchSlide since the last search (section 10).
  if (!m_surfaces.empty() && slide_since_search(u) > m_search_slide && search(u)) evaluate(u, false);
}

void ContactSystem::update_slip(const VectorXd& u) {
  if (!tracks_slip()) return;
  const Index np = size();
  for (Index k = 0; k < np; ++k) {
    const ContactPair& c = m_pairs[k];
    const double w = c.tangent().dot(Vec2(u[2 * c.j] - u[2 * c.i], u[2 * c.j + 1] - u[2 * c.i + 1]));
    const PairResult& r = m_result[k];
    const double kt = m_law.tangential_factor * c.stiffness / c.gap0;
    if (r.status == PairStatus::open)
      m_slip[k] = w;  // an open pair stores no tangential force
    else if (r.status == PairStatus::slip)
      m_slip[k] = w - r.tangential / kt;
  }
}

double ContactSystem::slide_since_search(const VectorXd& u) const {
  if (m_surfaces.empty()) return 0.0;
  double slide = 0.0;
  for (const ContactPair& c : m_pairs) {
    if (excluded(c)) continue;
    const Vec2 d(u[2 * c.j] - m_u_search[2 * c.j] - u[2 * c.i] + m_u_search[2 * c.i],
                 u[2 * c.j + 1] - m_u_search[2 * c.j + 1] - u[2 * c.i + 1] + m_u_search[2 * c.i + 1]);
    slide = std::max(slide, std::abs(c.tangent().dot(d)));
  }
  return max_over_ranks(slide);
}

bool ContactSystem::search(const VectorXd& u) {
  const Particles& p = m_model.particles;
  const Index n = p.size();
  const double R = m_search_radius;
  std::unordered_set<std::uint64_t> known;
  known.reserve(2 * m_pairs.size());
  const auto key = [n](Index i, Index j) { return static_cast<std::uint64_t>(i) * n + j; };
  for (const ContactPair& c : m_pairs) known.insert(key(c.i, c.j));
  const auto current = [&](Index q) { return Vec2(p.position[q].x() + u[2 * q], p.position[q].y() + u[2 * q + 1]); };
  const Index before = size();
  for (const Surface& surface : m_surfaces) {
    // Side b in a grid of cells R wide over its current positions.
    std::unordered_map<std::uint64_t, std::vector<Index>> grid;
    for (Index j : surface.side_b) {
      const auto [cx, cy] = grid_cell(current(j), R);
      grid[cell_key(cx, cy)].push_back(j);
    }
    for (Index i : surface.side_a) {
      const Vec2 xi = current(i);
      visit_near(grid, xi, R, [&](Index j) {
        if ((current(j) - xi).norm() >= R) return;
        const Index lo = gid(i) < gid(j) ? i : j, hi = lo == i ? j : i;
        if (!counted(lo) && !counted(hi)) return;  // a part's pairs touch its own particles
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
        if (add_candidate(lo, hi, normal, u)) known.insert(key(lo, hi));
      });
    }
  }
  m_u_search = u;
  ++m_searches;
  // On a part, every rank changes its version when any rank found a pair: the solvers rebuild
  // what depends on the pairs together.
  if (m_law.exact && partitioned())
    m_augmentation_capped = max_over_ranks(m_augmentation_capped ? 1.0 : 0.0) > 0.0;
  if (max_over_ranks(size() > before ? 1.0 : 0.0) == 0.0) return false;
  if (partitioned()) {  // the new pairs in the whole model's order too
    std::vector<Index> order(static_cast<std::size_t>(size() - before));
    for (std::size_t k = 0; k < order.size(); ++k) order[k] = before + static_cast<Index>(k);
    std::sort(order.begin(), order.end(), [this](Index a, Index b) {
      return std::pair(gid(m_pairs[a].i), gid(m_pairs[a].j)) <
             std::pair(gid(m_pairs[b].i), gid(m_pairs[b].j));
    });
    const auto reorder = [&](auto& values) {  // the new entries of a per-pair vector, in `order`
      if (values.empty()) return;
      std::vector<typename std::decay_t<decltype(values)>::value_type> moved;
      for (const Index k : order) moved.push_back(values[static_cast<std::size_t>(k)]);
      std::copy(moved.begin(), moved.end(), values.begin() + before);
    };
    reorder(m_pairs);
    reorder(m_slip);
    reorder(m_multiplier);
    reorder(m_multiplier_committed);
    reorder(m_boost);
    reorder(m_last_violation);
    reorder(m_boost_limit);
  }
  m_counts.candidates = size();
  m_round_start = size();
  build_incidence();
  ++m_version;
  return true;
}

bool ContactSystem::add_candidate(Index i, Index j, const Vec2& normal, const VectorXd& u) {
  const Particles& p = m_model.particles;
  const Vec2 X = p.position[j] - p.position[i];
  const double proj = normal.dot(X);
  if (std::abs(proj) < kMinGap * m_model.spacing) return false;
  ContactPair c;
  c.i = i;
  c.j = j;
  c.normal = proj > 0.0 ? normal : Vec2(-normal);
  c.gap0 = std::abs(proj);
  c.stiffness = pair_stiffness(i, j);
  append_state(c, u);
  m_pairs.push_back(c);
  return true;
}

void ContactSystem::append_state(const ContactPair& c, const VectorXd& u) {
  // A new pair starts as an open pair does: no stored tangential force, no multiplier.
  m_result.push_back(PairResult{});
  if (tracks_slip())
    m_slip.push_back(c.tangent().dot(Vec2(u[2 * c.j] - u[2 * c.i], u[2 * c.j + 1] - u[2 * c.i + 1])));
  if (m_law.velocity_sign) m_tangential_velocity.push_back(0.0);
  if (m_law.exact) {
    m_multiplier.push_back(0.0);
    m_multiplier_committed.push_back(0.0);
    m_boost.push_back(initial_boost(c));
    m_last_violation.push_back(0.0);
    m_boost_limit.push_back(boost_limit(c));
  }
}

void ContactSystem::save(StateArchive& archive) const {
  if (partitioned()) {
    // Every rank's own pairs with their slip, by global id in the whole model's order; the
    // displacement of the last search from the particles' owners (collective).
    // Per pair: i, j, normal, gap0, stiffness, then slip (friction), then the committed
    // multiplier, boost and boost limit (exact enforcement).
    const std::size_t width = 6 + (tracks_slip() ? 1 : 0) + (m_law.exact ? 3 : 0);
    std::vector<double> mine;
    for (std::size_t k = 0; k < m_pairs.size(); ++k) {
      const ContactPair& c = m_pairs[k];
      if (!counted(c.i)) continue;
      mine.insert(mine.end(), {static_cast<double>(gid(c.i)), static_cast<double>(gid(c.j)), c.normal.x(),
                               c.normal.y(), c.gap0, c.stiffness});
      if (tracks_slip()) mine.push_back(m_slip[k]);
      if (m_law.exact) mine.insert(mine.end(), {m_multiplier_committed[k], m_boost[k], m_boost_limit[k]});
    }
    const std::vector<double> all = m_ranks.gather(mine);
    std::vector<std::size_t> rows(all.size() / width);
    for (std::size_t r = 0; r < rows.size(); ++r) rows[r] = r * width;
    std::sort(rows.begin(), rows.end(), [&](std::size_t a, std::size_t b) {
      return std::pair(all[a], all[a + 1]) < std::pair(all[b], all[b + 1]);
    });
    std::vector<double> pairs, slip, multiplier, boost, boost_limit;
    for (const std::size_t r : rows) {
      pairs.insert(pairs.end(), all.begin() + static_cast<std::ptrdiff_t>(r),
                   all.begin() + static_cast<std::ptrdiff_t>(r + 6));
      std::size_t at = r + 6;
      if (tracks_slip()) slip.push_back(all[at++]);
      if (m_law.exact) {
        multiplier.push_back(all[at]);
        boost.push_back(all[at + 1]);
        boost_limit.push_back(all[at + 2]);
      }
    }
    archive.put("contact/pairs", std::move(pairs));
    if (tracks_slip()) archive.put("contact/slip", std::move(slip));
    if (m_law.exact) {
      archive.put("contact/multiplier", std::move(multiplier));
      archive.put("contact/boost", std::move(boost));
      archive.put("contact/boost_limit", std::move(boost_limit));
      archive.put("contact/augmentation_capped", m_augmentation_capped ? 1.0 : 0.0);
    }
    if (!m_surfaces.empty()) {
      std::vector<std::int64_t> ids;
      std::vector<double> values;
      for (Index q = 0; q < m_model.particles.size(); ++q)
        if (counted(q)) {
          ids.push_back(gid(q));
          values.insert(values.end(), {m_u_search[2 * q], m_u_search[2 * q + 1]});
        }
      archive.put("contact/u_search", m_ranks.gather_on_root(ids, values, 2, m_ranks.n_particles_whole));
      archive.put("contact/searches", m_searches);
    }
    return;
  }
  std::vector<double> pairs;
  pairs.reserve(6 * m_pairs.size());
  for (const ContactPair& c : m_pairs)
    pairs.insert(pairs.end(), {static_cast<double>(c.i), static_cast<double>(c.j), c.normal.x(), c.normal.y(), c.gap0,
                               c.stiffness});
  archive.put("contact/pairs", std::move(pairs));
  if (tracks_slip()) archive.put("contact/slip", m_slip);
  if (m_law.exact) {
    archive.put("contact/multiplier", m_multiplier_committed);
    archive.put("contact/boost", m_boost);
    archive.put("contact/boost_limit", m_boost_limit);
    archive.put("contact/augmentation_capped", m_augmentation_capped ? 1.0 : 0.0);
  }
  if (!m_surfaces.empty()) {
    archive.put("contact/u_search", {m_u_search.data(), m_u_search.data() + m_u_search.size()});
    archive.put("contact/searches", m_searches);
  }
}

void ContactSystem::restore(const StateArchive& archive) {
  const std::vector<double>& flat = archive.get("contact/pairs");
  if (flat.size() % 6 != 0) throw InputError("the checkpoint's 'contact/pairs' is not a list of pairs");
  const Index n = m_model.particles.size(), rows = static_cast<Index>(flat.size() / 6);
  const bool friction = tracks_slip();
  const std::vector<double> none;
  const std::vector<double>& slip = friction ? archive.get("contact/slip", rows) : none;
  const std::vector<double>& multiplier = m_law.exact ? archive.get("contact/multiplier", rows) : none;
  const std::vector<double>& boost = m_law.exact ? archive.get("contact/boost", rows) : none;
  const std::vector<double>& boost_limit = m_law.exact ? archive.get("contact/boost_limit", rows) : none;
  m_pairs.clear();
  m_slip.clear();
  m_multiplier_committed.clear();
  m_boost.clear();
  m_boost_limit.clear();
  for (Index k = 0; k < rows; ++k) {
    const double* v = &flat[6 * k];
    ContactPair c;
    if (partitioned()) {  // the pairs that touch this part's own particles
      const std::int64_t whole = m_ranks.n_particles_whole;
      const auto gi =
          static_cast<std::int64_t>(StateArchive::index(v[0], 0, static_cast<Index>(whole), "contact/pairs"));
      const auto gj =
          static_cast<std::int64_t>(StateArchive::index(v[1], 0, static_cast<Index>(whole), "contact/pairs"));
      c.i = local_of(gi);
      c.j = local_of(gj);
      const bool mine = (c.i >= 0 && counted(c.i)) || (c.j >= 0 && counted(c.j));
      if (!mine) continue;
      if (c.i < 0 || c.j < 0)
        throw InputError(
            "the checkpoint's contact pair (" + std::to_string(gi) + ", " + std::to_string(gj) +
            ") reaches past this rank's part of the model (the faces slid too far for the parts): "
            "resume with solver.belos.model=whole");
    } else {
      c.i = StateArchive::index(v[0], 0, n, "contact/pairs");
      c.j = StateArchive::index(v[1], 0, n, "contact/pairs");
    }
    c.normal = Vec2(v[2], v[3]);
    c.gap0 = v[4];
    c.stiffness = v[5];
    m_pairs.push_back(c);
    const auto row = static_cast<std::size_t>(k);
    if (friction) m_slip.push_back(slip[row]);
    if (m_law.exact) {
      m_multiplier_committed.push_back(multiplier[row]);
      m_boost.push_back(boost[row]);
      m_boost_limit.push_back(boost_limit[row]);
    }
  }
  const auto np = static_cast<Index>(m_pairs.size());
  m_result.assign(np, PairResult{});
  if (m_law.velocity_sign) m_tangential_velocity.assign(np, 0.0);
  if (m_law.exact) {
    m_multiplier = m_multiplier_committed;
    m_last_violation.assign(np, 0.0);
    m_augmentation_capped = archive.scalar("contact/augmentation_capped") != 0.0;
  }
  if (!m_surfaces.empty()) {
    if (partitioned()) {
      const std::vector<double>& u = archive.get("contact/u_search", 2 * m_ranks.n_particles_whole);
      m_u_search.resize(2 * n);
      for (Index q = 0; q < n; ++q)
        for (int d = 0; d < 2; ++d) m_u_search[2 * q + d] = u[static_cast<std::size_t>(2 * gid(q) + d)];
    } else {
      const std::vector<double>& u = archive.get("contact/u_search", 2 * static_cast<std::int64_t>(n));
      m_u_search = Eigen::Map<const VectorXd>(u.data(), static_cast<Eigen::Index>(u.size()));
    }
    m_searches = static_cast<int>(archive.scalar("contact/searches"));
  }
  m_counts = ContactCounts{};
  m_counts.candidates = m_counts.open = partitioned() ? rows : np;
  m_round_start = np;
  m_multiplier_updates = 0;
  build_incidence();
  ++m_version;
}

std::size_t ContactSystem::memory_bytes() const {
  auto bytes = [](const auto& v) { return v.capacity() * sizeof(v[0]); };
  return bytes(m_pairs) + bytes(m_slip) + bytes(m_tangential_velocity) + bytes(m_multiplier) +
         bytes(m_multiplier_committed) + bytes(m_boost) + bytes(m_last_violation) + bytes(m_result) +
         bytes(m_incident_start) + bytes(m_incident);
}

}  // namespace peristat
