// Adaptive Dynamic Relaxation (Kilic and Madenci 2010), the explicit path the paper uses,
// on the same Problem as Newton: the same residual (internal, contact and friction forces),
// the same relative residual measure and tolerance semantics. Derivation and choices:
// docs/theory/adr.md.
#pragma once

#include "assembly/pseudo_velocity.hpp"
#include "core/options.hpp"
#include "solvers/distribution.hpp"
#include "solvers/step_solver.hpp"

namespace peristat {

class AdrSolver final : public StepSolver {
 public:
  /// `velocity`: where the pseudo-velocity goes when the problem's residual reads one (the
  /// paper's velocity-sign friction); null otherwise.
  /// `share`: under mpirun, the unknowns this rank updates (docs/guide/distributed.md); each
  /// pseudo-time step then evaluates the rank's rows only (EvaluationMode::own_rows_only), updates
  /// its own unknowns, and shares them with every rank (on a rank's part: with the ranks that
  /// read them).
  AdrSolver(Problem& problem, const AdrOptions& options, PseudoVelocityInput* velocity = nullptr,
            UnknownShare share = {});

  /// Relaxes from x (at rest) to r(x) = 0 at the problem's current load factor.
  SolveReport solve(VectorXd& x, IterationObserver* observer = nullptr) override;
  /// Computes the fictitious density at the converged state x when the tangent may have
  /// changed (first call, or any call for a problem whose tangent is not constant).
  void prepare(const VectorXd& x) override;
  bool prepared() const override {
    return m_have_density && m_structure == m_problem.traits().structure_version;
  }
  bool cutback_helps() const override { return false; }
  bool breaks_while_solving() const override {
    return m_options.break_during && m_problem.irreversible_state() != nullptr;
  }
  /// max(rtol * force_scale, a floor of 1e-300 N), the convergence test of the pseudo-time steps.
  double residual_tolerance(double force_scale) const override;

  /// The fictitious density of the last prepare() (per unknown).
  const VectorXd& density() const { return m_density; }

 private:
  /// ||r|| at x and, with `damping`, the Rayleigh quotient's sums into num and den
  /// (distributed: over the ranks' own rows, in one sum in rank order).
  double measure(const VectorXd& x, bool damping, double& num, double& den) const;
  /// Distributed, after an update of the own unknowns: each rank's ghosts from their owners
  /// (the entries its rows read).
  void share_reads(VectorXd& x);
  /// One central-difference step with damping c: m_v and x updated (distributed: the own
  /// entries only; the others, which this rank's rows never read, stay until the solve ends).
  void take_step(VectorXd& x, double c);
  /// With breaking during the iterations: the bonds over the criterion at x break, and the
  /// fictitious density follows the changed stiffness. Returns how many broke.
  Index break_bonds(const VectorXd& x);
  /// The reason (and acceptance) of a solve that spent its budget at relative residual `relative`.
  void spent_budget(SolveReport& report, double relative) const;

  Problem& m_problem;
  PseudoVelocityInput* m_velocity;
  AdrOptions m_options;
  UnknownShare m_share;
  VectorXd m_density;
  SparseMatrix m_K;  ///< tangent for the row sums (pattern kept across load steps)
  bool m_have_density = false;
  std::uint64_t m_structure = 0;  ///< the problem's traits().structure_version of m_K
  VectorXd m_r, m_r_old, m_v;  ///< reused across solves: no allocation per iteration
};

}  // namespace peristat
