// The energy ledger of the accepted states (docs/theory/newton.md, "Energy balance"): the work
// of the forces over each increment between accepted states, and the check that the bonds'
// stored energy changes by the work of their forces.
#pragma once

#include <memory>
#include <span>
#include <string>

#include "contact/contact.hpp"
#include "core/state_archive.hpp"
#include "core/types.hpp"
#include "discretisation/model.hpp"
#include "materials/family_kernel.hpp"

namespace peristat {

struct ProblemOptions;

/// The energy ledger of the accepted states (docs/theory/newton.md, "Energy balance"), summed
/// over the increments between them by the trapezoid rule on the forces of the two states.
/// external_work + residual_work = strain_energy + contact_work + released + quadrature holds
/// exactly (up to round-off): `quadrature` is the trapezoid's error on the bonds' work over the
/// increments without breaking. The check of each such increment compares the change of the
/// stored energy with the work of the bond forces by a rule exact for the kernel's energy to
/// round-off (trapezoid, linearised kinematics) or to high order (Simpson, finite kinematics).
struct EnergyLedger {
  double external_work = 0.0;  ///< work of the forces on the prescribed components [J]
  double residual_work = 0.0;  ///< work of the residual forces on the unknowns (the solver's tolerance) [J]
  double strain_energy = 0.0;  ///< Pi of the bonds at the last accepted state [J]
  double contact_work = 0.0;   ///< work taken by the contact pairs: stored in them + dissipated by friction [J]
  double released = 0.0;       ///< work the bonds took over increments that broke bonds and no longer store [J]
  double quadrature = 0.0;     ///< accumulated (trapezoid work of the bond forces - change of Pi) [J]
  double worst_relative = 0.0; ///< largest |change of Pi - rule's work| / energy scale of a checked increment
  Index checked = 0;           ///< increments checked
};

/// The ledger, the last accepted state (full displacement, bond forces and contact forces, 2N
/// each) and the increment to a trial state, measured in three steps around the problem's
/// evaluations (begin_increment(), with Simpson's rule midpoint() and midpoint_forces(), then
/// finish_increment()) and pending until commit().
class EnergyBalance {
 public:
  /// Starts from the undeformed, unloaded state: no force, no energy. The energy scale of
  /// round-off is sum_i V_i E_i over the particles (on a part, its own, summed over the ranks)
  /// with E the modulus of each body's kernel. `options` (the problem's, which must outlive
  /// this) gives the rows and the collectives of a distributed run.
  EnergyBalance(const Model& model, std::span<const std::unique_ptr<FamilyKernel>> kernels, bool contact,
                bool small_kinematics, const ProblemOptions& options, const Ranks& ranks);
  EnergyBalance(const EnergyBalance&) = delete;
  EnergyBalance& operator=(const EnergyBalance&) = delete;

  /// The ledger up to the last accepted state.
  const EnergyLedger& ledger() const { return m_ledger; }
  /// Whether an increment was measured since the last evaluation (and passed its check).
  bool pending() const { return m_pending; }
  /// A new evaluation: the increment measured so far is not the last evaluation's.
  void discard() { m_pending = false; }
  /// Bonds broke since the accepted state (true), or the round that broke them was undone.
  void set_bonds_changed(bool changed) { m_bonds_changed = changed; }

  /// The increment from the accepted state to the state of the last evaluation: displacement
  /// u, internal force (bonds + contact) and the bonds' energy. Returns whether the check's
  /// rule needs the bond forces at the midpoint (finite kinematics, no bond broke): then the
  /// caller evaluates the bonds at midpoint() and hands their forces to midpoint_forces().
  /// On a part: collective.
  bool begin_increment(const VectorXd& u, const VectorXd& force, const ContactSystem* contact, double energy);
  /// The displacement halfway between the accepted state and the increment's end.
  void midpoint(VectorXd& u) const { u = 0.5 * (m_u_accepted + m_u_next); }
  /// Simpson's rule on the bond forces of the two states and of the midpoint.
  void midpoint_forces(const VectorXd& bond_force);
  /// Returns why the energy balance of the increment fails, or "" (failures are reported only
  /// when `check`); the increment is pending when it does not fail.
  std::string finish_increment(bool check);
  /// The pending increment joins the ledger; its end becomes the accepted state.
  void commit();
  /// The increment's end becomes the accepted state, the ledger unchanged (after a restore).
  void accept_state();
  /// The ledger into / from a checkpoint.
  void save(StateArchive& archive) const;
  void restore(const StateArchive& archive);
  std::size_t memory_bytes() const;

 private:
  const Model& m_model;
  const Ranks& m_ranks;
  bool m_contact;  ///< the contact forces are kept apart
  bool m_small_kinematics;
  double m_energy_unit = 0.0;  ///< sum of V_i E_i [J]: the energy scale of round-off
  EnergyLedger m_ledger, m_pending_ledger;
  bool m_pending = false;
  bool m_bonds_changed = false;  ///< bonds broke since the last accepted state
  VectorXd m_u_accepted, m_fbond_accepted, m_fcontact_accepted;
  VectorXd m_u_next, m_fbond_next, m_fcontact_next;
  // The increment being measured: its end's energy, the change of Pi, the bonds' trapezoid
  // work and the rule's work.
  double m_energy_next = 0.0, m_change = 0.0, m_bond_work = 0.0, m_rule = 0.0;
};

}  // namespace peristat
