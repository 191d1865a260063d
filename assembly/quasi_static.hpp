// The quasi-static peridynamic problem: total energy Pi(u) = sum_i V_i W_i over the bond
// families, prescribed components eliminated. Residual and tangent are its first and second
// derivatives, assembled in parallel by gathering per particle (deterministic, no atomics).
#pragma once

#include <memory>
#include <vector>

#include "assembly/pattern.hpp"
#include "assembly/problem.hpp"
#include "contact/contact.hpp"
#include "discretisation/model.hpp"
#include "materials/osb.hpp"

namespace peristat {

class QuasiStaticProblem final : public Problem {
 public:
  QuasiStaticProblem(const Model& model, const Scene& scene);

  Index n_unknowns() const override { return m_model.constraints.n_free; }
  void set_load_factor(double lambda) override;
  double load_factor() const override { return m_lambda; }
  void evaluate(const VectorXd& x, VectorXd& r, SparseMatrix* K) override;
  double force_scale() const override { return m_force_scale; }
  /// The first call hands over the pattern built at construction (no copy of a matrix that
  /// can hold hundreds of MB); later calls rebuild it.
  SparseMatrix make_tangent() const override;
  /// False while a pair slips with friction (the Jacobian of eq 14 is not symmetric).
  bool tangent_symmetric() const override { return !m_contact || m_contact->symmetric(); }
  bool tangent_constant() const override { return m_linear && !m_contact && !m_failure.enabled; }
  std::uint64_t state_signature() const override { return m_contact ? m_contact->signature() : 0; }
  /// The bond-based part of the tangent restricted to bonds shorter than
  /// solver.krylov.bond_radius * dx: sum of V alpha' omega w M M^T with alpha' = 8 mu / m'
  /// and m' the weighted volume of those bonds (docs/theory/newton.md, "Bond preconditioner"),
  /// plus k_n n n^T (+ k_t t t^T when sticking) of every contact pair in contact.
  SparseMatrix make_preconditioner() const override;
  void assemble_preconditioner(SparseMatrix& P) override;
  void commit(const VectorXd& x) override;
  /// Every candidate pair, whatever its state: 4 x ContactSystem::stiffness_bound on the two
  /// components of both particles (a 2 x 2 block appears twice in a row, +J and -J).
  void add_stiffness_bound(VectorXd& row_sums) const override;
  /// The scene's failure criterion (docs/theory/failure.md) at x: a bond breaks when
  /// max(value/critical) over its two directions exceeds 1; the most critical
  /// `failure.fraction` of those (at least one) break.
  Index break_bonds(const VectorXd& x, Index at_most = 0) override;
  void undo_last_break() override;
  /// Bonds broken since the start (pairs), and the damage of each particle,
  /// 1 - sum of intact bond weights / sum of all (N).
  Index broken_bonds() const { return m_broken; }
  void damage(VectorXd& d) const;
  bool models_failure() const { return m_failure.enabled; }
  bool wants_velocity() const override { return m_contact && m_contact->wants_velocity(); }
  /// Expands v (unknowns) to all components, zero on prescribed ones, for the contact pairs.
  void set_velocity(const VectorXd& v) override;

  /// Full displacement (2N, interleaved) of x at the current load factor.
  void expand(const VectorXd& x, VectorXd& u) const;
  /// Internal force dPi/du of every component (2N) from the last evaluate; on prescribed
  /// components these are the reactions.
  const VectorXd& internal_force() const { return m_force; }
  /// First Piola stress at particle i from the last evaluate, P = sum_b t_b M_b xi_b^T: the
  /// derivative of W with respect to the deformation gradient when the family deforms
  /// homogeneously (docs/theory/osb.md, "Stress"). Meaningful away from boundaries.
  Mat2 stress(Index i) const;
  /// Total strain energy Pi [J] of the last evaluate.
  double energy() const { return m_energy; }
  const Model& model() const { return m_model; }
  /// The contact candidates and their state, or null when the scene has no contact.
  const ContactSystem* contact() const { return m_contact.get(); }
  /// Wall time spent building the contact candidates, and evaluating the pairs (summed over
  /// every evaluate so far) [s].
  double contact_setup_seconds() const { return m_contact_setup_seconds; }
  double contact_seconds() const { return m_contact_seconds; }
  const TangentPattern& pattern() const { return m_pattern; }

 private:
  /// m_eta of particle i's bonds from m_u.
  void family_displacements(Index i);
  void compute_families(bool want_tangent);
  void gather_forces();
  void gather_tangent(SparseMatrix& K) const;

  const Model& m_model;
  double m_contact_setup_seconds = 0.0;      ///< declared first: m_contact's initialiser sets it
  std::unique_ptr<ContactSystem> m_contact;  ///< null without contact: no candidates, no cost
  mutable TangentPattern m_pattern;  ///< its matrix is moved out by the first make_tangent()
  mutable std::unique_ptr<TangentPattern> m_bond_pattern;  ///< built on first request
  double m_bond_radius = 0.0;                              ///< [m]
  std::vector<double> m_bond_alpha_volume;                 ///< per particle V 8 mu / m'
  std::vector<OsbConstants> m_body_constants;              ///< per body
  std::vector<double> m_weighted_volume;                   ///< m_i (eq 4), intact bonds at the start
  std::vector<double> m_weight;  ///< bond quadrature weights, 0 once broken (the kernel's input)
  FailureOptions m_failure;
  std::vector<double> m_critical;        ///< per body: s_c or gamma_c
  std::vector<Index> m_reference_bond;   ///< skew: per particle, the reference bond (global index)
  std::vector<double> m_ratio;           ///< per bond: criterion value / critical (scratch)
  Index m_broken = 0;
  std::vector<Index> m_last_round;   ///< bonds (b < reverse) broken by the last round
  Index m_contact_before_round = 0;  ///< contact candidates before the last round
  bool m_linear = false;
  double m_contact_seconds = 0.0;
  double m_lambda = 0.0;

  // State of the last evaluate.
  VectorXd m_u, m_force;
  VectorXd m_velocity;  ///< full pseudo-velocity (velocity-sign friction only)
  double m_force_scale = 0.0, m_energy = 0.0;
  std::vector<Vec2> m_eta, m_direction, m_s;  ///< per bond
  std::vector<double> m_t;                    ///< per bond
  std::vector<Sym2> m_kbond;                  ///< per bond
  std::vector<Vec2> m_s_self;                 ///< per particle: -sum_b s_b
  std::vector<double> m_beta_volume;          ///< per particle: beta_i V_i
};

}  // namespace peristat
