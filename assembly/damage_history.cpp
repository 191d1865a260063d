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

DamageHistory::DamageHistory(const Model& model, const BondFailure* failure, const ProblemOptions& options,
                             const Ranks& ranks)
    : m_model(model), m_failure(failure), m_options(options), m_ranks(ranks) {
  if (m_failure) m_damage_accepted = VectorXd::Zero(model.particles.size());
}

std::string DamageHistory::check() {
  if (!m_failure) return {};
  m_failure->damage(m_damage_now);
  // The first particle whose damage decreased: (its whole model's index, position, before,
  // after); on a part, each rank's own particles, the smallest index over the ranks.
  struct Healed {
    std::int64_t id;
    double x, y, before, after;
  };
  std::vector<Healed> found;
  for (Index i = 0; i < m_damage_now.size(); ++i) {
    if (!m_options.rows.counts(i)) continue;
    if (m_damage_now[i] >= m_damage_accepted[i] - kDamageRoundOff) continue;
    const Vec2& X = m_model.particles.position[i];
    found = {{m_failure->global(i), X.x(), X.y(), m_damage_accepted[i], m_damage_now[i]}};
    break;
  }
  {
    const std::vector<Healed> all = m_ranks.all_gather(found);
    found.clear();
    for (const Healed& h : all)
      if (found.empty() || h.id < found[0].id) found = {h};
  }
  if (found.empty()) return {};
  const Healed& h = found[0];
  char buf[320];
  std::snprintf(buf, sizeof buf,
                "the damage of particle %lld at (%.6g, %.6g) m decreased from %.6g to %.6g: broken bonds healed",
                static_cast<long long>(h.id), h.x, h.y, h.before, h.after);
  return buf;
}

void DamageHistory::commit() {
  if (!m_failure) return;
  m_failure->damage(m_damage_now);
  m_damage_accepted.swap(m_damage_now);
}

}  // namespace peristat
