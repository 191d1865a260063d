#include "contact/contact.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/Cholesky>

namespace peristat {

/// A pair Jacobian is symmetric when its off-diagonal entries agree to this fraction of its
/// largest entry (round-off of n n^T and t t^T products).
constexpr double kSymmetryTolerance = 1e-12;

/// The violations a multiplier update reports (MultiplierUpdate::kind), by rank-neutral index.
constexpr const char* kClosure = "closure";
constexpr const char* kOpeningUnderLoad = "opening under load";
constexpr const char* kStuckSlip = "stuck slip";
constexpr const char* kKinds[] = {kClosure, kOpeningUnderLoad, kStuckSlip};

ContactLaw ContactSystem::law_of(const ContactOptions& o, double spacing) {
  ContactLaw law;
  law.normal = o.normal;
  law.radius = o.radius_factor * spacing;
  law.gate = o.gate;
  law.friction = o.friction;
  law.tangential_factor = o.tangential_factor;
  law.velocity_sign = o.velocity_sign && o.friction > 0.0;
  law.exact = o.enforcement == ContactEnforcement::exact;
  law.stick_multiplier = law.exact && o.exact_stick;
  law.closure_reference = o.closure_reference;
  law.window = spacing;
  return law;
}

ContactSystem::ContactSystem(const Model& model, const ContactOptions& o, const Ranks& ranks, ContactRanks share)
    : m_model(model),
      m_ids(std::move(share), model.particles.size(), ranks),
      m_law(law_of(o, model.spacing)),
      m_stiffness(model, o.stiffness, m_law.exact),
      m_search(model, m_law, m_ids, m_stiffness),
      m_state(m_law, m_stiffness),
      m_closure_tolerance(o.closure_tolerance),
      m_max_multiplier_updates(o.max_multiplier_updates) {
  start_candidates(o);
  count_candidates();
  build_incidence();
}

void ContactSystem::start_candidates(const ContactOptions& o) {
  m_state.start(m_search.find_reference_pairs(o));
  m_result.assign(size(), PairResult{});
}

void ContactSystem::count_candidates() {
  // Every rank's own pairs (every pair of a whole model).
  Index own = 0;
  for (const ContactPair& c : pairs()) own += counted(c.i);
  m_counts.candidates = static_cast<Index>(m_ids.sum_over_ranks(own));
  m_counts.open = m_counts.candidates;
  if (m_law.exact) m_state.reduce_augmentation_capped(m_ids);
}

void ContactSystem::add_pair(const ContactPair& c, const VectorXd& u) {
  m_state.append(c, u);  // no stored tangential force: like a pair that was open
  m_result.push_back(PairResult{});
}

void ContactSystem::add_broken_bonds(const std::vector<std::pair<Index, Index>>& bonds, const VectorXd& u) {
  const Particles& p = m_model.particles;
  m_state.start_round();
  for (const auto& [a, b] : bonds) {
    const Index i = gid(a) < gid(b) ? a : b, j = i == a ? b : a;
    if (p.fictitious[i] || p.fictitious[j]) continue;
    if (!counted(i) && !counted(j)) continue;  // a part holds the pairs that touch its own particles
    const Vec2 X = p.position[j] - p.position[i];
    ContactPair c;
    c.i = i;
    c.j = j;
    c.normal = X.normalized();  // a broken bond's faces meet along the bond
    c.from_bond = true;
    c.gap0 = X.norm();
    c.stiffness = m_stiffness(i, j);
    add_pair(c, u);
  }
  m_counts.candidates = size();
  build_incidence();
}

void ContactSystem::drop_last_round() {
  if (!m_state.drop_last_round()) return;  // the round added no pair
  m_result.resize(static_cast<std::size_t>(size()));
  m_counts.candidates = size();
  build_incidence();
}

void ContactSystem::build_incidence() {
  const Index n = m_model.particles.size();
  const Index np = size();
  const std::vector<ContactPair>& pairs = m_state.pairs();
  // Incidence CSR: the pairs of each particle.
  m_incident_start.assign(n + 1, 0);
  for (const ContactPair& c : pairs) {
    ++m_incident_start[c.i + 1];
    ++m_incident_start[c.j + 1];
  }
  for (Index q = 0; q < n; ++q) m_incident_start[q + 1] += m_incident_start[q];
  m_incident.resize(m_incident_start[n]);
  std::vector<Index> fill(m_incident_start.begin(), m_incident_start.end() - 1);
  for (Index k = 0; k < np; ++k) {
    m_incident[fill[pairs[k].i]++] = {k, pairs[k].j, -1};
    m_incident[fill[pairs[k].j]++] = {k, pairs[k].i, +1};
  }
}

void ContactSystem::evaluate(const VectorXd& u, bool want_jacobian) {
  const Particles& p = m_model.particles;
  const std::vector<ContactPair>& pairs = m_state.pairs();
  const Index np = size();
#pragma omp parallel for schedule(static)
  for (Index k = 0; k < np; ++k) {
    const ContactPair& c = pairs[k];
    if (excluded(c)) {
      m_result[k] = PairResult{};
      continue;
    }
    const Vec2 du(u[2 * c.j] - u[2 * c.i], u[2 * c.j + 1] - u[2 * c.i + 1]);
    const PairHistory history = m_state.history(k);
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
    if (!counted(pairs[k].i)) continue;  // on a part: another rank's pair
    const PairStatus s = m_result[k].status;
    const Mat2& J = m_result[k].J;
    symmetric = symmetric && std::abs(J(0, 1) - J(1, 0)) <= kSymmetryTolerance * J.cwiseAbs().maxCoeff();
    counts.open += s == PairStatus::open;
    counts.stick += s == PairStatus::stick;
    counts.slip += s == PairStatus::slip;
    hash = (hash ^ static_cast<std::uint64_t>(s)) * 1099511628211ull;
    const ContactPair& c = pairs[k];
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
  reduce_over_ranks(want_jacobian);
}

void ContactSystem::reduce_over_ranks(bool want_jacobian) {
  // Each rank's figures of its own pairs; every rank combines them in rank order alike.
  Index own = 0;
  for (const ContactPair& c : pairs()) own += counted(c.i);
  struct Figures {
    std::int64_t candidates, open, stick, slip;
    double min_distance, max_closure;
    std::int64_t symmetric;
    std::uint64_t signature;
  };
  const Figures mine{own,
                     m_counts.open,
                     m_counts.stick,
                     m_counts.slip,
                     own > 0 ? m_min_distance : std::numeric_limits<double>::infinity(),
                     m_max_closure,
                     m_symmetric ? 1 : 0,
                     m_signature};
  ContactCounts counts;
  std::uint64_t hash = 1469598103934665603ull;
  double dmin = std::numeric_limits<double>::infinity(), closure = 0.0;
  bool symmetric = true;
  for (const Figures& f : m_ids.gather(std::vector<Figures>{mine})) {
    counts.candidates += static_cast<Index>(f.candidates);
    counts.open += static_cast<Index>(f.open);
    counts.stick += static_cast<Index>(f.stick);
    counts.slip += static_cast<Index>(f.slip);
    dmin = std::min(dmin, f.min_distance);
    closure = std::max(closure, f.max_closure);
    symmetric = symmetric && f.symmetric != 0;
    // FNV-1a over each rank's signature, 16 bits at a time.
    for (int q = 0; q < 4; ++q) hash = (hash ^ ((f.signature >> (16 * q)) & 0xffff)) * 1099511628211ull;
  }
  m_counts = counts;
  m_signature = hash;
  if (want_jacobian) m_symmetric = symmetric;
  m_min_distance = counts.candidates > 0 ? dmin : 0.0;
  m_max_closure = closure;
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
  const std::vector<ContactPair>& pairs = m_state.pairs();
  for (std::size_t k = 0; k < pairs.size(); ++k) {
    const int s = static_cast<int>(m_result[k].status);  // open 0, stick 1, slip 2
    out[pairs[k].i] = std::max(out[pairs[k].i], s);
    out[pairs[k].j] = std::max(out[pairs[k].j], s);
  }
}

Mat2 ContactSystem::preconditioner_block(Index k) const {
  const PairResult& r = m_result[k];
  if (r.status == PairStatus::open) return Mat2::Zero();
  return closed_pair_block(pairs()[k], m_state.boost(k), m_law.stick_scale(m_state.boost(k)),
                           r.status == PairStatus::stick);
}

double ContactSystem::stiffness_bound(Index k) const {
  const ContactPair& c = pairs()[k];
  if (m_law.exact) {  // phi C / a along n, plus the window ramp carrying lambda + C s (s <= 1)
    const double ca = m_state.boost(k) * c.stiffness;
    double b = ca / c.gap0;
    if (m_law.gate > 0.0) b += (multiplier(k) + ca) / (m_law.gate * m_law.window);
    if (m_law.friction > 0.0) b += m_law.stick_scale(m_state.boost(k)) * c.stiffness / c.gap0;
    return b;
  }
  double b = c.stiffness * (1.0 / c.gap0 + 1.0 / m_law.radius);
  if (m_law.friction > 0.0) b += m_law.tangential_factor * c.stiffness / c.gap0;
  if (m_law.normal == NormalLaw::paper && m_law.gate > 0.0) b += c.stiffness / (m_law.gate * m_law.radius);
  return b;
}

void ContactSystem::set_velocity(const VectorXd& v) { m_state.set_velocity(v); }

void ContactSystem::start_trial(double ratio) { m_state.start_trial(ratio); }

namespace {

/// The small strain (exx, eyy, exy) that fits the stretches of particle i's bonds with a
/// weight at u best (least squares over its family, each bond by its weight: `weight`'s, one
/// per bond, or the model's when it is empty); zero when the intact bonds do not span the three
/// components.
Eigen::Vector3d family_strain(const Model& model, Index i, const VectorXd& u,
                              std::span<const double> weight) {
  const Bonds& b = model.bonds;
  Eigen::Matrix3d A = Eigen::Matrix3d::Zero();
  Eigen::Vector3d r = Eigen::Vector3d::Zero();
  const std::span<const double> model_w = b.weights(i);
  for (Index k = b.start[i]; k < b.start[i + 1]; ++k) {
    const double w = weight.empty() ? model_w[static_cast<std::size_t>(k - b.start[i])] : weight[k];
    if (w <= 0.0) continue;
    const Index j = b.neighbour[k];
    const Vec2 xi = model.xi(i, k);
    const double L2 = xi.squaredNorm();
    const Vec2 eta(u[2 * j] - u[2 * i], u[2 * j + 1] - u[2 * i + 1]);
    const double stretch = xi.dot(eta) / L2;  // linearised: xi.eta / |xi|^2
    const Eigen::Vector3d g(xi.x() * xi.x() / L2, xi.y() * xi.y() / L2, 2.0 * xi.x() * xi.y() / L2);
    A += w * g * g.transpose();
    r += w * stretch * g;
  }
  const Eigen::LDLT<Eigen::Matrix3d> ldlt(A);
  if (A.trace() <= 0.0 || ldlt.info() != Eigen::Success || !ldlt.isPositive() ||
      std::abs(ldlt.vectorD().minCoeff()) < 1e-8 * A.trace())
    return Eigen::Vector3d::Zero();
  return ldlt.solve(r);
}

}  // namespace

double ContactSystem::pair_strain(const ContactPair& c, const VectorXd& u,
                                  std::span<const double> bond_weights) {
  double e[3] = {0.0, 0.0, 0.0};
  for (const Index q : {c.i, c.j}) {
    if (!m_family_strain_done[q]) {
      m_family_strain[q] = family_strain(m_model, q, u, bond_weights);
      m_family_strain_done[q] = 1;
    }
    for (int d = 0; d < 3; ++d) e[d] += 0.5 * m_family_strain[q][d];
  }
  const Vec2& n = c.normal;
  return std::min(0.0, n.x() * n.x() * e[0] + n.y() * n.y() * e[1] + 2.0 * n.x() * n.y() * e[2]);
}

MultiplierUpdate ContactSystem::worst_over_ranks(const MultiplierUpdate& mine) const {
  // The largest over every rank's own pairs; of equals, the first in the whole model's order.
  struct Worst {
    double violation, opening;
    std::int64_t i, j;
    int kind;  // index into kKinds: a pointer means nothing on another rank
  };
  auto kind_index = [](const char* kind) {
    return kind == kStuckSlip ? 2 : kind == kOpeningUnderLoad ? 1 : 0;
  };
  MultiplierUpdate best = mine;
  best.violation = 0.0;
  best.opening = 0.0;
  best.pair_i = best.pair_j = -1;
  int best_kind = 0;
  for (const Worst& w : m_ids.gather(std::vector<Worst>{
           {mine.violation, mine.opening, mine.pair_i, mine.pair_j, kind_index(mine.kind)}})) {
    best.opening = std::max(best.opening, w.opening);
    if (w.violation > best.violation || (w.i >= 0 && w.violation == best.violation && best.pair_i >= 0 &&
                                         std::pair(w.i, w.j) < std::pair(best.pair_i, best.pair_j))) {
      best.violation = w.violation;
      best.pair_i = w.i;
      best.pair_j = w.j;
      best_kind = w.kind;
    }
  }
  best.kind = kKinds[best_kind];
  return best;
}

MultiplierUpdate ContactSystem::update_multipliers(const VectorXd& u, std::span<const double> bond_weights) {
  MultiplierUpdate m;
  if (!m_law.exact) return m;
  if (m_law.material_closure()) {
    // The strains at u first: the violations below measure the closure the next solve
    // enforces (the forces at u were computed with the previous strains).
    m_family_strain.resize(static_cast<std::size_t>(m_model.particles.size()));
    m_family_strain_done.assign(static_cast<std::size_t>(m_model.particles.size()), 0);
  }
  evaluate(u, false);
  const Particles& p = m_model.particles;
  const std::vector<ContactPair>& pairs = m_state.pairs();
  const Index np = size();
  // Facing pairs (the kernel's exact branch): within one spacing across and along.
  // Under exact stick a stuck pair's slip from its anchor, |w - w_p| / a, is a violation too.
  std::vector<double> closure(np, 0.0), violation(np, 0.0), strain(m_law.material_closure() ? np : 0, 0.0);
  std::vector<char> facing(np, 0);
  for (Index k = 0; k < np; ++k) {
    const ContactPair& c = pairs[k];
    const Vec2 du(u[2 * c.j] - u[2 * c.i], u[2 * c.j + 1] - u[2 * c.i + 1]);
    const PairGap g = pair_gap(c, p.position[c.j] - p.position[c.i], du);
    if (c.gap0 > m_law.window * (1.0 + kLatticeRoundOff) || std::abs(g.tangential) >= m_law.window) continue;
    facing[k] = 1;
    closure[k] = 1.0 - g.normal / c.gap0;
    if (m_law.strain_reference(c)) {
      strain[k] = pair_strain(c, u, bond_weights);
      closure[k] += strain[k];
    }
    // Weighted by the window: a pair whose cells face each other over part of a face holds
    // that part of it, and its force phi (lambda + C_a s) answers an update by phi C_a s
    // (on the ramp's end, 2.5% of a full pair's: the held fragment's corner pairs stalled).
    const double phi = window_weight(std::abs(g.tangential), m_law);
    violation[k] = phi * (m_result[k].normal_force > 0.0 ? std::abs(closure[k]) : std::max(0.0, closure[k]));
    const char* kind = closure[k] < 0.0 ? kOpeningUnderLoad : kClosure;
    if (m_result[k].status == PairStatus::stick) {
      const double slip = m_state.stick_violation(k, c.tangent().dot(du));
      if (slip > violation[k]) {
        violation[k] = slip;
        kind = kStuckSlip;
      }
    }
    if (!counted(c.i)) continue;  // on a part: another rank's pair (updated alike below)
    if (m_result[k].normal_force > 0.0) m.opening = std::max(m.opening, -closure[k]);
    if (violation[k] > m.violation) {
      m.violation = violation[k];
      m.pair_i = gid(c.i);
      m.pair_j = gid(c.j);
      m.kind = kind;
    }
  }
  m = worst_over_ranks(m);
  m.updates = m_state.updates();
  if (m.violation <= m_closure_tolerance) return m;
  if (m_state.updates() >= m_max_multiplier_updates) {
    m.status = MultiplierUpdate::Status::exhausted;
    return m;
  }
  // The new strains only with an update: an accepted state keeps those its forces were solved with.
  if (m_law.material_closure())
    for (Index k = 0; k < np; ++k)
      if (facing[k]) m_state.set_strain(k, strain[k]);
  m.updates = m_state.update_multipliers(facing, closure, violation, m_result, m_closure_tolerance);
  m.status = MultiplierUpdate::Status::updated;
  return m;
}

CrossedPair ContactSystem::first_crossed_pair(const VectorXd& u) const {
  const Particles& p = m_model.particles;
  CrossedPair out;
  const Index k = first_crossed(u);
  if (k >= 0) {
    const ContactPair& c = pairs()[k];
    const Vec2 du(u[2 * c.j] - u[2 * c.i], u[2 * c.j + 1] - u[2 * c.i + 1]);
    out = {gid(c.i), gid(c.j), p.position[c.i], p.position[c.j],
           pair_gap(c, p.position[c.j] - p.position[c.i], du).normal};
  }
  // Every rank's first own crossed pair; the first of those in the whole model's order.
  struct Crossed {
    std::int64_t i, j;
    double xi, yi, xj, yj, normal;
  };
  CrossedPair first;
  for (const Crossed& c : m_ids.gather(
           std::vector<Crossed>{{out.i, out.j, out.Xi.x(), out.Xi.y(), out.Xj.x(), out.Xj.y(), out.normal}})) {
    if (c.i < 0 || (first.any() && std::pair(first.i, first.j) < std::pair(c.i, c.j))) continue;
    first = {c.i, c.j, Vec2(c.xi, c.yi), Vec2(c.xj, c.yj), c.normal};
  }
  return first;
}


Index ContactSystem::first_crossed(const VectorXd& u) const {
  const Particles& p = m_model.particles;
  const std::vector<ContactPair>& pairs = m_state.pairs();
  const Index np = size();
  for (Index k = 0; k < np; ++k) {
    const ContactPair& c = pairs[k];
    if (excluded(c) || !counted(c.i)) continue;  // on a part: its own pairs
    const Vec2 du(u[2 * c.j] - u[2 * c.i], u[2 * c.j + 1] - u[2 * c.i + 1]);
    if (crossed(pair_gap(c, p.position[c.j] - p.position[c.i], du), m_model.spacing)) return k;
  }
  return -1;
}

void ContactSystem::commit(const VectorXd& u) {
  m_state.commit_trial();
  evaluate(u, false);
  m_state.update_slip(u, m_result);
  // Large sliding: partners are searched again in the current configuration once the faces
  // have slid by the search's trigger since the last search (section 10), by more than
  // rounding: a face whose grip moves it by exactly the trigger in a step (the test's plates,
  // 0.5 mm a step against 0.5 spacings) slid 0.49999999999999997 mm in one process and
  // 0.50000000000000023 mm on four ranks, and the two searched at different steps.
  constexpr double kBeyondRounding = 1.0 + 1e-9;
  if (m_search.has_faces() && slide_since_search(u) > kBeyondRounding * m_search.slide_trigger() && search(u))
    evaluate(u, false);
}

double ContactSystem::slide_since_search(const VectorXd& u) const {
  if (!m_search.has_faces()) return 0.0;
  double slide = 0.0;
  for (const ContactPair& c : pairs()) {
    if (excluded(c)) continue;
    slide = std::max(slide, m_search.slide(c, u));
  }
  return m_ids.max_over_ranks(slide);
}

bool ContactSystem::search(const VectorXd& u) {
  const Index before = size();
  for (const ContactPair& c : m_search.find_partners(pairs(), u)) add_pair(c, u);
  // On a part, every rank changes its version when any rank found a pair: the solvers rebuild
  // what depends on the pairs together.
  if (m_law.exact) m_state.reduce_augmentation_capped(m_ids);
  if (m_ids.max_over_ranks(size() > before ? 1.0 : 0.0) == 0.0) return false;
  m_state.sort_from(before, m_ids);  // the new pairs in the whole model's order, on every part alike
  m_counts.candidates = size();
  m_state.start_round();
  build_incidence();
  ++m_version;
  return true;
}

void ContactSystem::save(StateArchive& archive) const {
  m_state.save(archive, m_ids);  // collective on a part, then the search's
  m_search.save(archive);
}

void ContactSystem::restore(const StateArchive& archive) {
  const Index rows = m_state.restore(archive, m_ids);
  m_result.assign(size(), PairResult{});
  m_search.restore(archive);
  m_counts = ContactCounts{};
  m_counts.candidates = m_counts.open = rows;
  build_incidence();
  ++m_version;
}

std::size_t ContactSystem::memory_bytes() const {
  auto bytes = [](const auto& v) { return v.capacity() * sizeof(v[0]); };
  return m_state.memory_bytes() + bytes(m_result) + bytes(m_incident_start) + bytes(m_incident);
}

}  // namespace peristat
