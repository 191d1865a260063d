// Newton's method with backtracking line search on a Problem (docs/theory/newton.md).
// Keeps the tangent's pattern and the symbolic factorisation across iterations and load
// steps; factorises once per run when the tangent is constant or `tangent: initial` (again
// after a failed attempt or broken bonds).
// While the tangent is unsymmetric (contact pairs slipping with friction) a symmetric-only
// solver (CHOLMOD, LDLT) hands over to UMFPACK.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "assembly/problem.hpp"
#include "core/options.hpp"
#include "solvers/linear/linear_solver.hpp"
#include "solvers/step_solver.hpp"

namespace peristat {

class NewtonSolver final : public StepSolver {
 public:
  NewtonSolver(Problem& problem, LinearSolver& linear, const NewtonOptions& options);

  /// Solves r(x) = 0 at the problem's current load factor, starting from x.
  /// On failure x holds the last iterate (the caller restores its converged state).
  SolveReport solve(VectorXd& x, IterationObserver* observer = nullptr) override;

  /// Factorises the tangent at x (a converged state, at the current load factor). The
  /// first iteration of the next solve uses this factor: the Euler predictor of the new
  /// step is computed with the tangent of the converged state, not of the state whose
  /// prescribed components have just jumped (docs/theory/newton.md, "Predictor").
  void prepare(const VectorXd& x) override;
  /// True when a factor usable for the first iteration of the next solve exists, and the
  /// tangent of the last converged state with it.
  bool prepared() const override {
    return m_have_factor && !m_tangent_skipped && m_structure == m_problem.traits().structure_version;
  }
  /// The Euler predictor x + dx, K(x) dx = -(r(x; from) + dr/dlambda (to - from)), with the
  /// factor of the converged state x and dr/dlambda by central differences at a thousandth
  /// of the increment: the linearised response to the prescribed increment, in place of the
  /// residual of the state whose prescribed components have jumped (docs/theory/newton.md,
  /// "Predictor"). Keeps x when there is no factor or the solve fails. r(x; from) is
  /// prepare()'s when x and the problem are those prepare() saw (no contact: a contact scene
  /// evaluates it with touching pairs closed).
  SolveReport predict(VectorXd& x, double from) override;
  /// Forget the factorisation (after a failed solve, or when the pattern changed).
  void invalidate_factorization() override { m_have_factor = false; }
  /// max(rtol * force_scale, atol), the convergence test of every iterate.
  double residual_tolerance(double force_scale) const override;
  void set_reproducible(bool reproducible) override { m_reproducible = reproducible; }
  void set_last_load(bool last) override { m_last_load = last; }

 private:
  SolveReport solve_iterations(VectorXd& x, IterationObserver* observer, SolveReport report);
  /// The problem's residual at x into r and, with `tangent`, its tangent into m_K (whose
  /// symmetry it records; a tangent left out at the last load is then no longer missing).
  void evaluate(const VectorXd& x, VectorXd& r, bool tangent);
  /// The residual at x, with the tangent unless the first iteration keeps the factor it has
  /// (`use_existing`, cleared when the predictor changed the active set); returns its norm.
  /// When m_r already holds prepare()'s residual at this x (a re-solve after breaking), it
  /// is not evaluated again.
  double evaluate_first(const VectorXd& x, bool& use_existing, SolveReport& report);
  /// True when m_r holds prepare()'s residual at x and `load_factor`: the same bits of x,
  /// load factor and problem state (active set, broken bonds) as prepare() saw, and no
  /// evaluation by this solver since.
  bool residual_is_prepared(const VectorXd& x, double load_factor) const;
  /// Backtracking along m_dx from x: the accepted trial in m_trial, m_trial_r, its residual's
  /// norm in `norm` and its step length in `alpha`; false (with the reason) when none is.
  /// `expect_converged`: the full step is evaluated without the tangent, which is evaluated
  /// after all when that trial is accepted and does not converge.
  bool line_search(const VectorXd& x, double& norm, double& alpha, bool expect_converged,
                   SolveReport& report);
  /// Whether the full step of the linear solve just made is expected to converge at the last
  /// load, where the converged state's tangent goes unused: the Krylov solve's residual
  /// estimate says the linear model's residual meets the tolerance, and so does Newton's
  /// quadratic term estimated from the residuals `norm` and `previous_norm` (0: none yet).
  bool expect_converged(const LinearSolver& lin, double norm, double previous_norm) const;
  double relative(double norm) const;  ///< a residual norm relative to the force scale
  bool converged(double norm) const;   ///< whether a residual norm meets the tolerance
  /// The relative residual the Krylov solve of iteration `it` stops at, from the residual
  /// norms of this and the previous iterate and the previous forcing term.
  double forcing_term(int it, double norm, double previous_norm, double previous_eta) const;
  bool reuse_factor() const;
  long factorizations() const;
  void factorize(SolveReport& report);
  /// m_dx = K^-1 (-m_r) with `lin`, a Krylov solve stopping at `rtol` (0: its configured
  /// floor), timed from t0 (a deferred set-up inside it counts as set-up).
  void solve_linear(LinearSolver& lin, double rtol, SolveReport& report, double t0);

  /// The linear solver for the current tangent: m_linear, or UMFPACK (m_unsymmetric, made on
  /// first need) while the tangent is unsymmetric and m_linear needs a symmetric matrix.
  LinearSolver& select_solver();
  /// Makes the matrices and the symbolic analyses again when the problem's pattern changed.
  void follow_structure();

  Problem& m_problem;
  LinearSolver& m_linear;
  std::unique_ptr<LinearSolver> m_unsymmetric;
  LinearSolver* m_factored = nullptr;  ///< the solver holding the current factor
  bool m_unsymmetric_analyzed = false;
  bool m_K_symmetric = true;  ///< whether the tangent held in m_K is symmetric
  NewtonOptions m_options;
  SparseMatrix m_K;
  bool m_analyzed = false;
  bool m_have_factor = false;
  std::uint64_t m_structure = 0;  ///< the problem's traits().structure_version of m_K
  std::uint64_t m_factor_state = 0;  ///< the problem's traits().state_signature when the factor was built
  bool m_reproducible = true;        ///< see StepSolver::set_reproducible()
  bool m_last_load = false;          ///< see StepSolver::set_last_load()
  /// The last converged evaluation left the tangent out (the problem's is an earlier
  /// iterate's): the next solve evaluates it at its first iterate, prepare() at its x.
  bool m_tangent_skipped = false;
  SolveReport m_pending;  ///< work of prepare(), added to the next report
  /// What m_r holds after prepare(): the residual at its x and load factor, for the
  /// predictor's r(x; from) or the first iterate of a re-solve at that x (residual_is_prepared),
  /// until the next evaluation by this solver.
  struct PreparedResidual {
    bool valid = false;
    double load_factor = 0.0;
    std::uint64_t problem_state = 0;  ///< traits().preconditioner_state: active set, broken bonds
    std::uint64_t x_bits = 0;         ///< bits_fingerprint(x)
  } m_prepared_r;
  VectorXd m_r, m_dx, m_trial, m_trial_r, m_rhs;
};

}  // namespace peristat
