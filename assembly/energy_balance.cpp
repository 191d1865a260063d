#include "assembly/energy_balance.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <vector>

#include "assembly/quasi_static.hpp"

namespace peristat {

namespace {
/// The energy balance of an increment without breaking holds to this fraction of the energy
/// scale (measured: below 1e-9 on the cases, round-off of sums over every family).
constexpr double kEnergyTolerance = 1e-6;
/// Forces that vanish up to round-off (a rigid motion) do work of about 1e-16 E V per
/// spacing moved; 1e-14 leaves a margin of 100.
constexpr double kRoundOffWork = 1e-14;
}  // namespace

EnergyBalance::EnergyBalance(const Model& model, std::span<const std::unique_ptr<FamilyKernel>> kernels,
                             bool contact, bool small_kinematics, const ProblemOptions& options,
                             const Ranks& ranks)
    : m_model(model), m_ranks(ranks), m_contact(contact), m_small_kinematics(small_kinematics) {
  const Index n = model.particles.size();
  m_u_accepted = m_fbond_accepted = VectorXd::Zero(2 * n);
  if (contact) m_fcontact_accepted = VectorXd::Zero(2 * n);
  for (Index i = 0; i < n; ++i)
    if (options.rows.contains(i))  // its own particles (every one in one process), summed over the ranks
      m_energy_unit += model.particles.volume[i] * kernels[model.particles.body[i]]->modulus();
  m_energy_unit = ranks.sum(m_energy_unit);
}

bool EnergyBalance::begin_increment(const VectorXd& u, const VectorXd& force, const ContactSystem* contact,
                                    double energy) {
  const Index n2 = u.size();
  m_u_next = u;
  m_fbond_next = force;
  if (contact) {
    m_fcontact_next.setZero(n2);
    contact->add_internal_force(m_fcontact_next);
    m_fbond_next -= m_fcontact_next;
  }
  m_energy_next = energy;
  EnergyLedger& L = m_pending_ledger;
  L = m_ledger;
  L.strain_energy = m_energy_next;
  const std::vector<Index>& free = m_model.constraints.free_index;
  // On a part, each rank's particles' work (the ghosts' forces are zero here), summed over the ranks.
  double work[4] = {0.0, 0.0, 0.0, 0.0};  // bonds, contact, on the unknowns, on the prescribed components
  for (Index d = 0; d < n2; ++d) {
    const double du = m_u_next[d] - m_u_accepted[d];
    const double fb = 0.5 * (m_fbond_accepted[d] + m_fbond_next[d]);
    const double fc = m_fcontact_accepted.size() ? 0.5 * (m_fcontact_accepted[d] + m_fcontact_next[d]) : 0.0;
    work[0] += fb * du;
    work[1] += fc * du;
    work[free[d] >= 0 ? 2 : 3] += (fb + fc) * du;
  }
  for (double& w : work) w = m_ranks.sum(w);
  m_bond_work = work[0];
  L.contact_work += work[1];
  L.residual_work += work[2];
  L.external_work += work[3];
  m_change = m_energy_next - m_ledger.strain_energy;
  if (m_bonds_changed) {
    L.released += m_bond_work - m_change;
    return false;
  }
  // The rule's work of the bond forces: the trapezoid is exact for the quadratic energy of
  // linearised kinematics; finite kinematics use Simpson's rule with the bond forces at the
  // midpoint (one more evaluation of the families, then x's again).
  m_rule = m_bond_work;
  return !m_small_kinematics;
}

void EnergyBalance::midpoint_forces(const VectorXd& bond_force) {
  const Index n2 = m_u_next.size();
  double rule = 0.0;
  for (Index d = 0; d < n2; ++d)
    rule += (m_fbond_accepted[d] + 4.0 * bond_force[d] + m_fbond_next[d]) * (m_u_next[d] - m_u_accepted[d]);
  m_rule = m_ranks.sum(rule) / 6.0;
}

std::string EnergyBalance::finish_increment(bool check) {
  std::string why;
  if (!m_bonds_changed) {
    EnergyLedger& L = m_pending_ledger;
    const Index n2 = m_u_next.size();
    L.quadrature += m_bond_work - m_change;
    // The tolerance: a fraction of the energy scale; the round-off of forces that are zero up
    // to round-off doing work over a large motion (rigid motion); and for Simpson's rule a
    // tenth of its distance from the trapezoid's (an estimate of the trapezoid's error, of
    // which Simpson's is a higher order: measured 1e-4 of it for 3% stretch + 5% shear in one step).
    double max_du = 0.0;
    for (Index d = 0; d < n2; ++d) max_du = std::max(max_du, std::abs(m_u_next[d] - m_u_accepted[d]));
    max_du = m_ranks.max(max_du);
    const double scale =
        std::max({std::abs(m_energy_next), std::abs(m_ledger.strain_energy), std::abs(m_bond_work)});
    const double tolerance = kEnergyTolerance * scale + 0.1 * std::abs(m_rule - m_bond_work) +
                             kRoundOffWork * m_energy_unit * std::max(1.0, max_du / m_model.spacing);
    const double relative = std::abs(m_rule - m_change) / std::max(scale, std::numeric_limits<double>::min());
    L.worst_relative = std::max(L.worst_relative, relative);
    ++L.checked;
    if (check && !(std::abs(m_rule - m_change) <= tolerance)) {
      char buf[400];
      std::snprintf(buf, sizeof buf,
                    "energy balance: the bonds' stored energy changed by %.6e J over the increment, the work of "
                    "their forces was %.6e J (difference %.2e J, tolerance %.2e J): the bond forces are not the "
                    "derivative of the stored energy",
                    m_change, m_rule, std::abs(m_rule - m_change), tolerance);
      why = buf;
    }
  }
  m_pending = why.empty();
  return why;
}

void EnergyBalance::commit() {
  m_ledger = m_pending_ledger;
  accept_state();
}

void EnergyBalance::accept_state() {
  m_pending = m_bonds_changed = false;
  m_u_accepted.swap(m_u_next);
  m_fbond_accepted.swap(m_fbond_next);
  if (m_contact) m_fcontact_accepted.swap(m_fcontact_next);
}

void EnergyBalance::save(StateArchive& archive) const {
  const EnergyLedger& e = m_ledger;
  archive.put("problem/energy_ledger", {e.external_work, e.residual_work, e.strain_energy, e.contact_work, e.released,
                                        e.quadrature, e.worst_relative, static_cast<double>(e.checked)});
}

void EnergyBalance::restore(const StateArchive& archive) {
  const std::vector<double>& e = archive.get("problem/energy_ledger", 8);
  m_ledger = EnergyLedger{e[0], e[1], e[2], e[3], e[4], e[5], e[6], static_cast<Index>(e[7])};
}

std::size_t EnergyBalance::memory_bytes() const {
  return static_cast<std::size_t>(m_u_accepted.size() + m_fbond_accepted.size() + m_fcontact_accepted.size() +
                                  m_u_next.size() + m_fbond_next.size() + m_fcontact_next.size()) *
         sizeof(double);
}

}  // namespace peristat
