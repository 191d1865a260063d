#include "assembly/damage_history.hpp"

#include <cstdio>
#include <vector>

#include "assembly/quasi_static.hpp"

namespace peristat {

namespace {
/// Damage is a ratio of sums of weights: a value below the accepted one by more than this is
/// a healed bond, not round-off.
constexpr double kDamageRoundOff = 1e-12;
}  // namespace

DamageHistory::DamageHistory(const Model& model, const BondFailure* failure, const ProblemOptions& options)
    : m_model(model), m_failure(failure), m_options(options) {
  if (m_failure) m_damage_accepted = VectorXd::Zero(model.particles.size());
}

std::string DamageHistory::check() {
  if (!m_failure) return {};
  m_failure->damage(m_damage_now);
  // The first particle whose damage decreased: (its whole model's index, position, before,
  // after); on a part, each rank's own particles, the smallest index over the ranks.
  const bool part = on_part(m_options);
  std::vector<double> found;
  for (Index i = 0; i < m_damage_now.size(); ++i) {
    if (part && !m_options.rows.counts(i)) continue;
    if (m_damage_now[i] >= m_damage_accepted[i] - kDamageRoundOff) continue;
    const Vec2& X = m_model.particles.position[i];
    found = {static_cast<double>(m_failure->global(i)), X.x(), X.y(), m_damage_accepted[i], m_damage_now[i]};
    break;
  }
  if (part) {
    const std::vector<double> all = m_options.gather_over_ranks(found);
    found.clear();
    for (std::size_t at = 0; at < all.size(); at += 5)
      if (found.empty() || all[at] < found[0])
        found.assign(all.begin() + static_cast<std::ptrdiff_t>(at),
                     all.begin() + static_cast<std::ptrdiff_t>(at + 5));
  }
  if (found.empty()) return {};
  char buf[320];
  std::snprintf(
      buf, sizeof buf,
      "the damage of particle %ld at (%.6g, %.6g) m decreased from %.6g to %.6g: broken bonds healed",
      static_cast<long>(found[0]), found[1], found[2], found[3], found[4]);
  return buf;
}

void DamageHistory::commit() {
  if (!m_failure) return;
  m_failure->damage(m_damage_now);
  m_damage_accepted.swap(m_damage_now);
}

}  // namespace peristat
