#include "materials/bond_failure.hpp"

#include <algorithm>
#include <cmath>
#include <functional>
#include <numbers>

#include "materials/failure.hpp"
#include "materials/osb.hpp"

namespace peristat {

BondFailure::BondFailure(const Model& model, const FailureOptions& options)
    : m_model(model),
      m_options(options),
      m_min_sin(std::sin(options.skew_min_angle * std::numbers::pi / 180.0)),
      m_weight(model.bonds.weight) {
  const Bonds& bonds = model.bonds;
  const Index n = model.particles.size();
  for (const BodyInfo& body : model.bodies) {
    const double mu = shear_modulus(body.material);
    m_critical.push_back(
        options.criterion == FailureCriterion::skew
            ? critical_skew(options.G_c, mu, model.horizon)
            : critical_stretch(options.G_c, bulk_modulus_2d(body.material), mu, model.horizon));
  }
  if (options.criterion == FailureCriterion::skew) {
    m_reference_bond.assign(n, -1);
    for (Index i = 0; i < n; ++i) {
      const Index b0 = bonds.start[i], nb = bonds.family_size(i);
      const Index r = reference_bond(std::span(bonds.xi).subspan(b0, nb), options.direction);
      if (r >= 0) m_reference_bond[i] = b0 + r;
    }
  }
  m_ratio.assign(bonds.neighbour.size(), 0.0);
}

const std::vector<std::pair<Index, Index>>& BondFailure::break_over_criterion(std::span<const Vec2> eta,
                                                                              Index at_most) {
  m_round.clear();
  m_round_bonds.clear();
  m_round_references.clear();
  const Bonds& bonds = m_model.bonds;
  const Particles& p = m_model.particles;
  const Index n = p.size();
  const bool skew = m_options.criterion == FailureCriterion::skew;
#pragma omp parallel for schedule(static)
  for (Index i = 0; i < n; ++i) {
    const Index b0 = bonds.start[i], nb = bonds.family_size(i);
    const double critical = m_critical[p.body[i]];
    if (skew) {
      if (m_reference_bond[i] < 0) continue;
      bond_skews(std::span(bonds.xi).subspan(b0, nb), eta.subspan(b0, nb), m_reference_bond[i] - b0, m_min_sin,
                 std::span(m_ratio).subspan(b0, nb));
      for (Index b = b0; b < b0 + nb; ++b) m_ratio[b] /= critical;
    } else {
      for (Index b = b0; b < b0 + nb; ++b) m_ratio[b] = bond_stretch(bonds.xi[b], eta[b]) / critical;
    }
  }
  // Candidates: intact pairs (b < reverse) whose larger ratio of the two directions exceeds 1.
  m_over.clear();
  m_peak = Peak{};
  for (Index b = 0; b < bonds.n_bonds(); ++b) {
    const Index r = bonds.reverse[b];
    if (b > r || m_weight[b] == 0.0) continue;
    if (p.fictitious[bonds.neighbour[b]] && p.fictitious[bonds.neighbour[r]]) continue;
    const double ratio = std::max(m_ratio[b], m_ratio[r]);
    if (ratio > m_peak.ratio) m_peak = Peak{ratio, b};
    if (ratio > 1.0) m_over.emplace_back(ratio, b);
  }
  if (m_over.empty()) return m_round;
  std::sort(m_over.begin(), m_over.end(), std::greater<>());
  auto count = std::max<std::size_t>(
      1, static_cast<std::size_t>(std::ceil(m_options.fraction * static_cast<double>(m_over.size()))));
  if (at_most > 0) count = std::min(count, static_cast<std::size_t>(at_most));
  for (std::size_t k = 0; k < count; ++k) {
    const Index b = m_over[k].second;
    m_weight[b] = 0.0;
    m_weight[bonds.reverse[b]] = 0.0;
    m_round.emplace_back(bonds.neighbour[bonds.reverse[b]], bonds.neighbour[b]);
    m_round_bonds.push_back(b);
  }
  m_broken += static_cast<Index>(count);
  if (skew) {
    // A particle whose reference bond broke measures its skew against the closest intact
    // bond from now on: the broken one's rotation contains the crack's slip.
    for (const Index b : m_round_bonds) {
      for (const Index c : {b, bonds.reverse[b]}) {
        const Index i = bonds.neighbour[bonds.reverse[c]];
        if (m_reference_bond[i] != c) continue;
        const Index b0 = bonds.start[i], nb = bonds.family_size(i);
        const Index r = reference_bond(std::span(bonds.xi).subspan(b0, nb), m_options.direction,
                                       std::span<const double>(m_weight).subspan(b0, nb));
        m_round_references.emplace_back(i, c);
        m_reference_bond[i] = r >= 0 ? b0 + r : -1;
      }
    }
  }
  return m_round;
}

void BondFailure::commit() {
  m_round.clear();
  m_round_bonds.clear();
  m_round_references.clear();
}

void BondFailure::revert() {
  const Bonds& bonds = m_model.bonds;
  for (const Index b : m_round_bonds) {
    m_weight[b] = bonds.weight[b];
    m_weight[bonds.reverse[b]] = bonds.weight[bonds.reverse[b]];
  }
  m_broken -= static_cast<Index>(m_round_bonds.size());
  for (auto it = m_round_references.rbegin(); it != m_round_references.rend(); ++it)
    m_reference_bond[it->first] = it->second;
  commit();
}

void BondFailure::damage(VectorXd& d) const {
  const Bonds& bonds = m_model.bonds;
  const Index n = m_model.particles.size();
  d.resize(n);
  for (Index i = 0; i < n; ++i) {
    double all = 0.0, intact = 0.0;
    for (Index b = bonds.start[i]; b < bonds.start[i + 1]; ++b) {
      all += bonds.weight[b];
      intact += m_weight[b];
    }
    d[i] = all > 0.0 ? 1.0 - intact / all : 0.0;
  }
}

void BondFailure::save(StateArchive& archive) const {
  const Bonds& bonds = m_model.bonds;
  std::vector<double> broken;
  for (Index b = 0; b < bonds.n_bonds(); ++b)
    if (b < bonds.reverse[b] && m_weight[b] == 0.0 && bonds.weight[b] != 0.0) broken.push_back(b);
  archive.put("failure/broken_bonds", std::move(broken));
  if (!m_reference_bond.empty()) archive.put("failure/reference_bonds", {m_reference_bond.begin(), m_reference_bond.end()});
}

void BondFailure::restore(const StateArchive& archive) {
  const Bonds& bonds = m_model.bonds;
  const Index nb = bonds.n_bonds();
  for (const double v : archive.get("failure/broken_bonds")) {
    const Index b = StateArchive::index(v, 0, nb, "failure/broken_bonds");
    m_weight[b] = m_weight[bonds.reverse[b]] = 0.0;
    ++m_broken;
  }
  if (!m_reference_bond.empty()) {
    const std::vector<double>& r = archive.get("failure/reference_bonds", static_cast<std::int64_t>(m_reference_bond.size()));
    for (std::size_t i = 0; i < r.size(); ++i)
      m_reference_bond[i] = r[i] < 0 ? -1 : StateArchive::index(r[i], 0, nb, "failure/reference_bonds");
  }
  commit();
}

std::size_t BondFailure::memory_bytes() const {
  return (m_critical.capacity() + m_weight.capacity() + m_ratio.capacity()) * sizeof(double) +
         m_reference_bond.capacity() * sizeof(Index) +
         m_round_references.capacity() * sizeof(std::pair<Index, Index>);
}

}  // namespace peristat
