// What load stepping needs of a nonlinear solver: solve r(x) = 0 at the problem's current
// load factor from a converged start. Newton (solvers/newton.hpp) and Adaptive Dynamic
// Relaxation (solvers/adr.hpp) implement it on the same Problem, hence the same kernels.
#pragma once

#include <string>
#include <vector>

#include "assembly/problem.hpp"

namespace peristat {

/// Outcome of one solve at a fixed load factor.
struct SolveReport {
  bool converged = false;
  /// The iteration budget ran out and the options say to keep the state anyway (ADR's
  /// `on_budget: accept`, the paper's fixed iteration count). Never set by Newton.
  bool accepted_unconverged = false;
  std::string reason;              ///< why it stopped (converged, max iterations, ...)
  int iterations = 0;              ///< Newton: linear solves; ADR: pseudo-time steps
  std::vector<double> residuals;   ///< relative residuals (Newton: every iterate; ADR: sampled)
  /// The relative residual recomputed from scratch at the final state by the load stepping
  /// (set only for states it checked for acceptance).
  double true_residual = 0.0;
  std::vector<double> increments;  ///< Newton: alpha ||dx|| / max(||x||, tiny) of each accepted update
  int factorizations = 0;
  int linear_iterations = 0;  ///< Krylov iterations, summed
  int predictor_solves = 0;   ///< linear solves of the Euler predictor (StepSolver::predict)
  /// Iterations after which the problem's discrete state (contact active set) differed
  /// from that of the previous iterate.
  int active_set_changes = 0;
  /// Bonds the solver broke itself (ADR with `breaking: iterations`); the load stepping's
  /// re-solves count theirs in StepReport::bonds_broken.
  Index bonds_broken = 0;
  double seconds_evaluate = 0.0;  ///< residual (+ tangent) assembly
  double seconds_factorize = 0.0;
  double seconds_solve = 0.0;
};

/// Told as a solve progresses (StepSolver::solve).
class IterationObserver {
 public:
  virtual ~IterationObserver() = default;
  /// An iterate: iteration, relative residual, a solver-specific number (Newton: the
  /// line-search step length; ADR: the damping coefficient) and the Krylov iterations of the
  /// linear solve that led to this iterate (Newton with an iterative linear solver, from
  /// iteration 1; 0 otherwise).
  virtual void iteration_done(int iteration, double relative_residual, double extra,
                              int linear_iterations) = 0;
};

class StepSolver {
 public:
  virtual ~StepSolver() = default;
  /// Solves r(x) = 0 at the problem's current load factor, starting from x. On failure x
  /// holds the last iterate (the caller restores its converged state). `observer` (if any) is
  /// told of the iterates.
  virtual SolveReport solve(VectorXd& x, IterationObserver* observer = nullptr) = 0;
  /// Called with the converged state before the load factor moves on.
  virtual void prepare(const VectorXd& /*x*/) {}
  /// False when prepare() must be called before the next solve.
  virtual bool prepared() const { return true; }
  /// The first iterate of a load (sub)step when the last accepted states give no secant: x
  /// holds the converged state at load factor `from` on entry, the problem is at the new load
  /// factor. Newton replaces x by its Euler (tangent) predictor; the default keeps x. Returns
  /// the work done (linear iterations, seconds), which counts towards the step.
  virtual SolveReport predict(VectorXd& /*x*/, double /*from*/) { return {}; }
  /// Forget state tied to a failed attempt.
  virtual void invalidate_factorization() {}
  /// Whether a smaller load increment can rescue a failed solve. ADR fails by running out
  /// of its iteration budget, which a smaller increment does not change much.
  virtual bool cutback_helps() const { return true; }
  /// True when solve() advances the problem's irreversible state itself (bonds break during
  /// the iterations): the load stepping then does not break bonds between equilibria.
  virtual bool breaks_while_solving() const { return false; }
  /// The largest residual norm ||r|| this solver accepts as converged when the problem's
  /// force scale is `force_scale` (the load stepping checks every accepted state against it,
  /// with the residual recomputed from scratch).
  virtual double residual_tolerance(double force_scale) const = 0;
  /// Whether the next solves' converged states must be reproducible by another path: true
  /// from the first checkpoint on, which a resumed run starts from with a new preconditioner
  /// and without the previous state's secant, and must still end where the uninterrupted run
  /// does (to 1e-10, issue 15). False only before it, for the first nominal step of a run
  /// from the unloaded state, which every run solves the same way. Newton then stops its
  /// last Krylov solve as soon as the tolerance allows (docs/theory/newton.md, "Inexact Newton").
  virtual void set_reproducible(bool /*reproducible*/) {}
  /// Whether the next solves are at the run's last load: their converged state's tangent is
  /// then not used by a later solve (a re-solve after breaking, or a step that follows all the
  /// same, calls prepare() first), and Newton may leave it out of the evaluation it expects to
  /// converge.
  virtual void set_last_load(bool /*last*/) {}
};

}  // namespace peristat
