#include "contact/contact_state.hpp"

#include <algorithm>
#include <cmath>
#include <string>
#include <type_traits>

#include "core/error.hpp"

namespace peristat {

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

/// Exact enforcement: the augmentation modulus starts at this multiple of the eq 17 modulus
/// when the scene gives no contact.stiffness. A stiffer start needs fewer multiplier updates
/// but slows each linear solve; exact against penalty on cases 4.1 and 4.3 (docs/theory/
/// contact.md, "Convergence rate"): 1.53 x and 1.41 x from 1, 1.36 x and 0.92 x from 5 (1.37 x and
/// 0.83 x with the window-weighted violation).
constexpr double kInitialAugmentationModulus = 5.0;

ContactState::ContactState(const ContactLaw& law, const PairStiffness& stiffness)
    : m_law(law), m_stiffness(stiffness) {}

double ContactState::boost_limit(const ContactPair& c) const {
  return kMaxAugmentationModulus * m_stiffness.with_modulus(c.i, c.j, 0.0) / c.stiffness;
}

double ContactState::initial_boost(const ContactPair& c) {
  // The augmentation modulus sets the rate only: by default kInitialAugmentationModulus,
  // raised per pair where an update does not reduce the violation; contact.stiffness when
  // the scene gives one, but never above the cap (a stiffer augmentation stalls Newton).
  const double limit = boost_limit(c);
  if (m_stiffness.modulus_override() <= 0.0) return std::min(kInitialAugmentationModulus, limit);
  const double requested = m_stiffness.with_modulus(c.i, c.j, m_stiffness.modulus_override()) / c.stiffness;
  if (requested > limit) m_augmentation_capped = true;
  return std::min(requested, limit);
}

void ContactState::start(std::vector<ContactPair> pairs) {
  m_pairs = std::move(pairs);
  const Index np = size();
  if (m_law.tracks_slip()) m_slip.assign(np, 0.0);
  if (m_law.velocity_sign) m_tangential_velocity.assign(np, 0.0);
  if (m_law.exact_stick()) {
    m_stick.assign(np, {});
    m_stick_committed.assign(np, {});
  }
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
  if (m_law.material_closure()) {
    m_strain.assign(np, 0.0);
    m_strain_committed.assign(np, 0.0);
  }
  m_round_start = np;
}

void ContactState::append(const ContactPair& c, const VectorXd& u) {
  // A new pair starts as an open pair does: no stored tangential force, no multiplier.
  if (m_law.tracks_slip())
    m_slip.push_back(c.tangent().dot(Vec2(u[2 * c.j] - u[2 * c.i], u[2 * c.j + 1] - u[2 * c.i + 1])));
  if (m_law.velocity_sign) m_tangential_velocity.push_back(0.0);
  if (m_law.exact_stick()) {
    m_stick.emplace_back();
    m_stick_committed.emplace_back();
  }
  if (m_law.exact) {
    m_multiplier.push_back(0.0);
    m_multiplier_committed.push_back(0.0);
    m_boost.push_back(initial_boost(c));
    m_last_violation.push_back(0.0);
    m_boost_limit.push_back(boost_limit(c));
  }
  if (m_law.material_closure()) {  // set at the first multiplier update
    m_strain.push_back(0.0);
    m_strain_committed.push_back(0.0);
  }
  m_pairs.push_back(c);
}

void ContactState::sort_from(Index first, const ContactIds& ids) {
  std::vector<Index> order(static_cast<std::size_t>(size() - first));
  for (std::size_t k = 0; k < order.size(); ++k) order[k] = first + static_cast<Index>(k);
  std::sort(order.begin(), order.end(), [&](Index a, Index b) {
    return std::pair(ids.gid(m_pairs[a].i), ids.gid(m_pairs[a].j)) <
           std::pair(ids.gid(m_pairs[b].i), ids.gid(m_pairs[b].j));
  });
  const auto reorder = [&](auto& values) {  // the entries from `first` of a per-pair vector, in `order`
    if (values.empty()) return;
    std::vector<typename std::decay_t<decltype(values)>::value_type> moved;
    for (const Index k : order) moved.push_back(values[static_cast<std::size_t>(k)]);
    std::copy(moved.begin(), moved.end(), values.begin() + first);
  };
  reorder(m_pairs);
  reorder(m_slip);
  reorder(m_stick);
  reorder(m_stick_committed);
  reorder(m_tangential_velocity);
  reorder(m_multiplier);
  reorder(m_multiplier_committed);
  reorder(m_boost);
  reorder(m_last_violation);
  reorder(m_boost_limit);
  reorder(m_strain);
  reorder(m_strain_committed);
}

bool ContactState::drop_last_round() {
  if (m_round_start == size()) return false;  // the round added no pair
  const auto n = static_cast<std::size_t>(m_round_start);
  m_pairs.resize(n);
  if (m_law.tracks_slip()) m_slip.resize(n);
  if (m_law.velocity_sign) m_tangential_velocity.resize(n);
  if (m_law.exact_stick()) {
    m_stick.resize(n);
    m_stick_committed.resize(n);
  }
  if (m_law.exact) {
    m_multiplier.resize(n);
    m_multiplier_committed.resize(n);
    m_boost.resize(n);
    m_last_violation.resize(n);
    m_boost_limit.resize(n);
  }
  if (m_law.material_closure()) {
    m_strain.resize(n);
    m_strain_committed.resize(n);
  }
  return true;
}

void ContactState::reduce_augmentation_capped(const ContactIds& ids) {
  m_augmentation_capped = ids.max_over_ranks(m_augmentation_capped ? 1.0 : 0.0) > 0.0;
}

void ContactState::set_velocity(const VectorXd& v) {
  if (!m_law.velocity_sign) return;
  const Index np = size();
  for (Index k = 0; k < np; ++k) {
    const ContactPair& c = m_pairs[k];
    m_tangential_velocity[k] =
        c.tangent().dot(Vec2(v[2 * c.j] - v[2 * c.i], v[2 * c.j + 1] - v[2 * c.i + 1]));
  }
}

void ContactState::start_trial(double ratio) {
  if (!m_law.exact) return;
  const Index np = size();
  for (Index k = 0; k < np; ++k) m_multiplier[k] = ratio * m_multiplier_committed[k];
  // Proportional loading, proportional strains (like the multipliers).
  if (m_law.material_closure())
    for (Index k = 0; k < np; ++k) m_strain[k] = std::min(0.0, ratio * m_strain_committed[k]);
  if (m_law.exact_stick()) {
    // A pair at the limit stays there (its force follows F); a stuck one's scales like lambda.
    for (Index k = 0; k < np; ++k)
      m_stick[k] = {ratio * m_stick_committed[k].force, m_stick_committed[k].limit_sign};
  }
  std::fill(m_last_violation.begin(), m_last_violation.end(), 0.0);
  m_multiplier_updates = 0;
}

int ContactState::update_multipliers(const std::vector<char>& facing, const std::vector<double>& closure,
                                     const std::vector<double>& violation, const std::vector<PairResult>& result,
                                     double closure_tolerance) {
  // Uzawa: lambda <- max(0, lambda + C_k s), for open pairs too: an open pair's force falls
  // by C_k times its gap. Releasing it at once when it opened beyond the tolerance made pairs
  // near zero closure flip between closed and open: the pressed blocks of
  // verification.CoulombBlock at tolerance 1e-9 then stalled at a closure of 2.9e-4 after 30
  // updates (2026-12-02). A pair whose violation above the tolerance fell by less than
  // kAugmentationReduction since the last update gets a stiffer augmentation (method of
  // multipliers, Bertsekas 1982, sec. 2.2): C_k = boost_k C, boost_k *= kBoost.
  // Exact stick, the same step along t (Simo and Laursen 1992), with the anchor w_p fixed at
  // the committed slip through the increment (backward Euler, as the penalty return map): a
  // stuck pair's multiplier takes the force mu + k_t (w - w_p) it carries, so the next solve
  // pulls its slip back; a sliding pair goes to the limit, +-f_c F at whatever F becomes; an
  // open pair carries nothing.
  const Index np = size();
  const bool stick = m_law.exact_stick();
  for (Index k = 0; k < np; ++k) {
    if (stick) set_tangential(k, facing[k] ? result[k] : PairResult{});
    if (!facing[k]) {
      m_multiplier[k] = 0.0;
      continue;
    }
    const double ck = m_boost[k] * m_pairs[k].stiffness;
    m_multiplier[k] = std::max(0.0, m_multiplier[k] + ck * closure[k]);
    if (violation[k] > closure_tolerance && m_last_violation[k] > 0.0 &&
        violation[k] > kAugmentationReduction * m_last_violation[k])
      m_boost[k] = std::min(m_boost_limit[k], kBoost * m_boost[k]);
    m_last_violation[k] = violation[k];
  }
  return ++m_multiplier_updates;
}

void ContactState::set_tangential(Index k, const PairResult& r) {
  switch (r.status) {
    case PairStatus::stick:  // the force it carries
      m_stick[k] = {r.tangential, 0.0};
      break;
    case PairStatus::slip:  // at the limit
      m_stick[k] = {0.0, r.tangential > 0.0 ? 1.0 : (r.tangential < 0.0 ? -1.0 : 0.0)};
      break;
    case PairStatus::open:  // nothing
      m_stick[k] = {};
      break;
  }
}

void ContactState::commit_trial() {
  m_round_start = size();
  m_multiplier_committed = m_multiplier;
  if (m_law.material_closure()) m_strain_committed = m_strain;
  m_multiplier_updates = 0;
}

void ContactState::update_slip(const VectorXd& u, const std::vector<PairResult>& result) {
  if (!m_law.tracks_slip()) return;
  const Index np = size();
  const bool stick = m_law.exact_stick();
  for (Index k = 0; k < np; ++k) {
    const ContactPair& c = m_pairs[k];
    const double w = c.tangent().dot(Vec2(u[2 * c.j] - u[2 * c.i], u[2 * c.j + 1] - u[2 * c.i + 1]));
    const PairResult& r = result[k];
    if (stick) {
      // A stuck pair keeps its anchor and multiplier (its slip from the anchor is within the
      // tolerance, and the next step pulls it back); a sliding pair stays at the limit from
      // where it is, an open one carries nothing from where it is.
      if (r.status != PairStatus::stick) {
        set_tangential(k, r);
        m_slip[k] = w;
      }
      m_stick_committed[k] = m_stick[k];
      continue;
    }
    const double kt = m_law.tangential_factor * c.stiffness / c.gap0;
    if (r.status == PairStatus::open)
      m_slip[k] = w;  // an open pair stores no tangential force
    else if (r.status == PairStatus::slip)
      m_slip[k] = w - r.tangential / kt;
  }
}

void ContactState::save(StateArchive& archive, const ContactIds& ids) const {
  // Every rank's own pairs by global id, in the whole model's order. Per pair: i, j, normal,
  // gap0, stiffness, then slip (friction), then the committed multiplier, boost and boost
  // limit (exact enforcement).
  const bool friction = m_law.tracks_slip();
  struct Saved {
    std::int64_t i, j;
    double nx, ny, gap0, stiffness, slip, multiplier, boost, boost_limit, tangential_multiplier, limit_sign,
        strain, from_bond;
  };
  std::vector<Saved> mine;
  mine.reserve(m_pairs.size());
  for (std::size_t k = 0; k < m_pairs.size(); ++k) {
    const ContactPair& c = m_pairs[k];
    if (!ids.counted(c.i)) continue;  // on a part: another rank's pair
    mine.push_back({ids.gid(c.i), ids.gid(c.j), c.normal.x(), c.normal.y(), c.gap0, c.stiffness,
                    friction ? m_slip[k] : 0.0, m_law.exact ? m_multiplier_committed[k] : 0.0,
                    m_law.exact ? m_boost[k] : 0.0, m_law.exact ? m_boost_limit[k] : 0.0,
                    m_law.exact_stick() ? m_stick_committed[k].force : 0.0,
                    m_law.exact_stick() ? m_stick_committed[k].limit_sign : 0.0,
                    m_law.material_closure() ? m_strain_committed[k] : 0.0, c.from_bond ? 1.0 : 0.0});
  }
  std::vector<Saved> all = ids.gather(mine);
  // The parts' pairs (in rank order) by global ids: the whole model's order.
  std::sort(all.begin(), all.end(),
            [](const Saved& a, const Saved& b) { return std::pair(a.i, a.j) < std::pair(b.i, b.j); });
  std::vector<double> pairs, slip, multiplier, boost, boost_limit, tangential, limit_sign, strain,
      from_bond;  // doubles
  for (const Saved& x : all) {
    pairs.insert(pairs.end(), {static_cast<double>(x.i), static_cast<double>(x.j), x.nx, x.ny, x.gap0, x.stiffness});
    if (friction) slip.push_back(x.slip);
    if (m_law.exact) {
      multiplier.push_back(x.multiplier);
      boost.push_back(x.boost);
      boost_limit.push_back(x.boost_limit);
    }
    if (m_law.exact_stick()) {
      tangential.push_back(x.tangential_multiplier);
      limit_sign.push_back(x.limit_sign);
    }
    if (m_law.material_closure()) {
      strain.push_back(x.strain);
      from_bond.push_back(x.from_bond);
    }
  }
  archive.put("contact/pairs", std::move(pairs));
  if (friction) archive.put("contact/slip", std::move(slip));
  if (m_law.exact) {
    archive.put("contact/multiplier", std::move(multiplier));
    archive.put("contact/boost", std::move(boost));
    archive.put("contact/boost_limit", std::move(boost_limit));
    archive.put("contact/augmentation_capped", m_augmentation_capped ? 1.0 : 0.0);
  }
  if (m_law.exact_stick()) {
    archive.put("contact/tangential_multiplier", std::move(tangential));
    archive.put("contact/tangential_limit_sign", std::move(limit_sign));
  }
  if (m_law.material_closure()) {
    archive.put("contact/strain", std::move(strain));
    archive.put("contact/from_bond", std::move(from_bond));
  }
}

Index ContactState::restore(const StateArchive& archive, const ContactIds& ids) {
  const std::vector<double>& flat = archive.get("contact/pairs");
  if (flat.size() % 6 != 0) throw InputError("the checkpoint's 'contact/pairs' is not a list of pairs");
  const auto rows = static_cast<Index>(flat.size() / 6);
  const auto whole = static_cast<Index>(ids.n_particles_whole());
  const bool friction = m_law.tracks_slip();
  const std::vector<double> none;
  const std::vector<double>& slip = friction ? archive.get("contact/slip", rows) : none;
  const std::vector<double>& multiplier = m_law.exact ? archive.get("contact/multiplier", rows) : none;
  const std::vector<double>& boost = m_law.exact ? archive.get("contact/boost", rows) : none;
  const std::vector<double>& boost_limit = m_law.exact ? archive.get("contact/boost_limit", rows) : none;
  const std::vector<double>& tangential =
      m_law.exact_stick() ? archive.get("contact/tangential_multiplier", rows) : none;
  const std::vector<double>& limit_sign =
      m_law.exact_stick() ? archive.get("contact/tangential_limit_sign", rows) : none;
  const std::vector<double>& strain = m_law.material_closure() ? archive.get("contact/strain", rows) : none;
  const std::vector<double>& from_bond =
      m_law.material_closure() ? archive.get("contact/from_bond", rows) : none;
  m_pairs.clear();
  m_slip.clear();
  m_stick_committed.clear();
  m_multiplier_committed.clear();
  m_boost.clear();
  m_boost_limit.clear();
  m_strain_committed.clear();
  for (Index k = 0; k < rows; ++k) {
    const double* v = &flat[6 * k];
    // The pairs that touch this part's own particles (every pair of a whole model).
    const std::int64_t gi = StateArchive::index(v[0], 0, whole, "contact/pairs");
    const std::int64_t gj = StateArchive::index(v[1], 0, whole, "contact/pairs");
    ContactPair c;
    c.i = ids.local_of(gi);
    c.j = ids.local_of(gj);
    const bool mine = (c.i >= 0 && ids.counted(c.i)) || (c.j >= 0 && ids.counted(c.j));
    if (!mine) continue;
    if (c.i < 0 || c.j < 0)
      throw InputError("the checkpoint's contact pair (" + std::to_string(gi) + ", " + std::to_string(gj) +
                       ") reaches past this rank's part of the model (the faces slid too far for the parts): "
                       "resume it on fewer ranks, or on one process");
    c.normal = Vec2(v[2], v[3]);
    c.gap0 = v[4];
    c.stiffness = v[5];
    c.from_bond = m_law.material_closure() && from_bond[static_cast<std::size_t>(k)] != 0.0;
    m_pairs.push_back(c);
    const auto row = static_cast<std::size_t>(k);
    if (friction) m_slip.push_back(slip[row]);
    if (m_law.exact_stick()) {
      m_stick_committed.push_back({tangential[row], limit_sign[row]});
    }
    if (m_law.exact) {
      m_multiplier_committed.push_back(multiplier[row]);
      m_boost.push_back(boost[row]);
      m_boost_limit.push_back(boost_limit[row]);
    }
    if (m_law.material_closure()) m_strain_committed.push_back(strain[row]);
  }
  const Index np = size();
  if (m_law.velocity_sign) m_tangential_velocity.assign(np, 0.0);
  if (m_law.exact_stick()) {
    m_stick = m_stick_committed;
  }
  if (m_law.exact) {
    m_multiplier = m_multiplier_committed;
    m_strain = m_strain_committed;
    m_last_violation.assign(np, 0.0);
    m_augmentation_capped = archive.scalar("contact/augmentation_capped") != 0.0;
  }
  m_round_start = np;
  m_multiplier_updates = 0;
  return rows;
}

std::size_t ContactState::memory_bytes() const {
  auto bytes = [](const auto& v) { return v.capacity() * sizeof(v[0]); };
  return bytes(m_pairs) + bytes(m_slip) + bytes(m_stick) + bytes(m_stick_committed) +
         bytes(m_tangential_velocity) + bytes(m_multiplier) + bytes(m_multiplier_committed) + bytes(m_boost) +
         bytes(m_last_violation) + bytes(m_boost_limit) + bytes(m_strain) + bytes(m_strain_committed);
}

}  // namespace peristat
