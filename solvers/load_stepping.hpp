// Load stepping: N equal steps to load factor 1; a failing step is halved (up to
// Loading::max_cutbacks times) and grown back after success; bonds that break at a converged
// state are followed by re-solves at the same load. A converged state is accepted only when
// the problem's multiplier constraints hold (else the multipliers are updated and the load
// solved again) and the problem's admissibility check passes (else the attempt fails and is
// cut back). Only accepted states (and states ADR keeps with `on_budget: accept`, counted as
// unconverged) are committed and reported.
#pragma once

#include <string>
#include <vector>

#include "core/options.hpp"
#include "solvers/step_solver.hpp"

namespace peristat {

/// One nominal load step k/N, possibly reached through several sub-steps.
struct StepReport {
  int step = 0;
  double load_factor = 0.0;
  int substeps = 0;
  int cutbacks = 0;
  int newton_iterations = 0;  ///< summed over sub-steps and re-solves (ADR: pseudo-time steps)
  int linear_iterations = 0;
  int predictor_solves = 0;  ///< Euler predictor solves (first sub-step, after cut-backs)
  int factorizations = 0;
  int active_set_changes = 0;     ///< Newton iterations that changed the contact active set
  int unconverged = 0;            ///< sub-steps kept unconverged (ADR `on_budget: accept`)
  Index bonds_broken = 0;         ///< bonds broken after this step's sub-steps converged
  int resolves = 0;               ///< re-solves at the same load after breaking bonds (incl. failed ones)
  int break_cutbacks = 0;         ///< failed re-solves retried with half as many bonds
  int multiplier_updates = 0;     ///< re-solves after updating constraint multipliers (exact contact)
  std::vector<double> residuals;  ///< relative residuals of all sub-steps, in order
  double final_residual = 0.0;    ///< relative residual recomputed from scratch at the final state
  double seconds_evaluate = 0.0, seconds_factorize = 0.0, seconds_solve = 0.0;
  double wall_seconds = 0.0;
};

struct RunReport {
  bool completed = false;
  int steps_done = 0;
  std::string message;
};

/// What run_load_steps tells as it goes; every method does nothing unless overridden.
class LoadSteppingObserver : public IterationObserver {
 public:
  /// A nominal step converged; x is its state (unknowns).
  virtual void step_done(const StepReport& /*step*/, const VectorXd& /*x*/) {}
  /// Start of an attempt at load factor lambda (sub-step or retry) of nominal step k.
  virtual void attempt_started(int /*step*/, int /*n_steps*/, double /*lambda*/, int /*cutbacks*/) {}
  /// Every Newton iterate (ADR: every report_every-th iterate, and the first and last).
  void iteration_done(int /*iteration*/, double /*relative_residual*/, double /*extra*/,
                      int /*linear_iterations*/) override {}
  /// Bonds broke at a converged state; the same load is solved again (re-solve k).
  virtual void bonds_broke(Index /*broken*/, int /*resolve*/) {}
  /// The re-solve after breaking `broken` bonds failed: they are restored and at most
  /// `next` of them (the most critical) break in the retry.
  virtual void resolve_failed(const std::string& /*reason*/, Index /*broken*/, Index /*next*/) {}
  /// A converged state violated its multiplier constraints by `violation`; the multipliers
  /// were updated (update k of this increment) and the same load is solved again.
  virtual void multipliers_updated(double /*violation*/, int /*update*/) {}
  /// An attempt failed and the step is cut back.
  virtual void cut_back(const std::string& /*reason*/, double /*next_increment*/) {}
};

/// Runs the load steps from the committed state x (normally zero at load factor 0): nominal
/// steps steps_done + 1 .. loading.steps, the problem's load factor being that of step
/// steps_done (a resumed run). `observer` is told of the steps, attempts and iterates.
/// Throws PartsOutgrown (core/error.hpp) when a converged state shows that the ranks' parts
/// must grow; x and the problem are then in the middle of a step.
RunReport run_load_steps(Problem& problem, StepSolver& solver, VectorXd& x, const Loading& loading,
                         LoadSteppingObserver& observer, int steps_done = 0);

}  // namespace peristat
