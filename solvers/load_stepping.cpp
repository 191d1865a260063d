#include "solvers/load_stepping.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <string>

#include "core/clock.hpp"
#include "core/error.hpp"

namespace peristat {

namespace {
/// A nominal step is reached when the load factor is within this fraction of the nominal
/// increment of its target: room for the round-off of halved and doubled increments.
constexpr double kReachedTarget = 1e-12;
/// Attempts (sub-steps and cut-backs) one nominal step may take: a step that keeps failing a
/// few halvings deep advances by a tiny fraction per two attempts and would never end.
constexpr int kMaxAttemptsPerStep = 500;

/// Adds one solve's work to the step's report.
void accumulate(StepReport& step, const SolveReport& r) {
  step.newton_iterations += r.iterations;
  step.linear_iterations += r.linear_iterations;
  step.predictor_solves += r.predictor_solves;
  step.factorizations += r.factorizations;
  step.active_set_changes += r.active_set_changes;
  step.bonds_broken += r.bonds_broken;
  step.seconds_evaluate += r.seconds_evaluate;
  step.seconds_factorize += r.seconds_factorize;
  step.seconds_solve += r.seconds_solve;
  step.residuals.insert(step.residuals.end(), r.residuals.begin(), r.residuals.end());
}

/// One solve at the problem's current load, with what a state needs before it is accepted:
/// while the multiplier constraints are violated, their update and a re-solve; then the
/// invariants of every accepted state, whatever the solver reported: the state is finite,
/// its residual recomputed from scratch is within the solver's tolerance (states ADR keeps
/// unconverged are exempt: they are counted as such), and the problem's own checks pass. A
/// state that fails any is reported as not converged, with the reason. Work is added to
/// `step`; `r_check` is scratch.
SolveReport solve_and_check(Problem& problem, StepSolver& solver, VectorXd& trial, VectorXd& r_check,
                            LoadSteppingObserver& observer, StepReport& step) {
  SolveReport r = solver.solve(trial, &observer);
  accumulate(step, r);
  while (r.converged) {
    const ConstraintUpdate m = problem.update_multipliers(trial);
    if (m.status == ConstraintUpdate::Status::satisfied) break;
    if (m.status == ConstraintUpdate::Status::exhausted) {
      r.converged = false;
      r.reason = m.message;
      return r;
    }
    ++step.multiplier_updates;
    observer.multipliers_updated(m.violation, m.updates);
    r = solver.solve(trial, &observer);
    accumulate(step, r);
  }
  if (!r.converged && !r.accepted_unconverged) return r;
  const auto reject = [&](std::string why) {
    r.converged = false;
    r.accepted_unconverged = false;
    r.reason = std::move(why);
    return r;
  };
  if (!problem.unknowns().all_finite(trial)) {
    Index k = 0;  // this rank's first (on a rank whose entries are all finite: none)
    while (k < trial.size() && std::isfinite(trial[k])) ++k;
    return reject(
        "the solver's state holds a non-finite value" +
        (k < trial.size() ? " (unknown " + std::to_string(k) + ")" : std::string(" on another rank")));
  }
  problem.evaluate(trial, r_check, nullptr);
  const double norm = problem.unknowns().norm(r_check), scale = problem.force_scale();
  r.true_residual = norm / std::max(scale, std::numeric_limits<double>::min());
  if (!std::isfinite(norm)) return reject("the residual recomputed at the solver's state is not finite");
  if (r.converged && norm > solver.residual_tolerance(scale)) {
    char buf[320];
    std::snprintf(
        buf, sizeof buf,
        "the residual recomputed at the solver's converged state, %.3e relative, exceeds the solver's "
        "tolerance (%.3e relative): the solver's convergence report was wrong",
        r.true_residual,
        solver.residual_tolerance(scale) / std::max(scale, std::numeric_limits<double>::min()));
    return reject(buf);
  }
  if (std::string why = problem.check_converged_state(trial); !why.empty()) return reject(std::move(why));
  return r;
}

/// A solve that converged (or was accepted unconverged): x takes its state, which is committed.
void accept(Problem& problem, VectorXd& x, VectorXd& trial, const SolveReport& r, StepReport& step) {
  if (!r.converged) ++step.unconverged;
  x.swap(trial);
  problem.commit(x);
  step.final_residual = r.true_residual;
}

/// Quasi-static breaking at the converged, committed state x of nominal step step.step of n,
/// load factor lambda: bonds over the criterion break and the same load is solved again until
/// none breaks (docs/theory/failure.md). A round whose re-solve fails is undone and retried
/// with half as many bonds (the most critical first), down to one bond; the cap doubles after
/// two rounds in a row converge. Returns "" or why the run has to stop (x is then the last
/// converged state).
std::string break_and_resolve(Problem& problem, StepSolver& solver, VectorXd& x, VectorXd& trial,
                              VectorXd& r_check, const Loading& loading, LoadSteppingObserver& observer,
                              StepReport& step, int n, double lambda) {
  const int k = step.step;
  char buf[320];
  Index at_most = 0;  // 0: no cap beyond failure.fraction
  int successes = 0;  // converged rounds since the last halving
  IrreversibleState* irreversible = problem.irreversible_state();
  if (!irreversible || solver.breaks_while_solving()) return {};  // nothing (else) can change: the step is done
  for (int resolve = 1;; ++resolve) {
    Index broken = 0;
    try {
      broken = irreversible->advance_irreversible_state(x, at_most);
    } catch (const ModelLimit& limit) {
      std::snprintf(buf, sizeof buf, "load step %d/%d: %s", k, n, limit.what());
      return buf;
    }
    if (broken == 0) return {};
    if (loading.max_resolves > 0 && resolve > loading.max_resolves) {
      irreversible->revert_irreversible_state();
      std::snprintf(buf, sizeof buf,
                    "load step %d/%d: bonds still breaking after %d re-solves at load factor %.6g "
                    "(loading.max_resolves)",
                    k, n, loading.max_resolves, lambda);
      return buf;
    }
    ++step.resolves;
    observer.bonds_broke(broken, resolve);
    solver.invalidate_factorization();
    solver.prepare(x);  // the tangent without the broken bonds
    trial = x;
    const SolveReport r = solve_and_check(problem, solver, trial, r_check, observer, step);
    if (r.converged || r.accepted_unconverged) {
      accept(problem, x, trial, r, step);
      step.bonds_broken += broken;
      if (at_most > 0 && ++successes >= 2) {
        at_most *= 2;
        successes = 0;
      }
      continue;
    }
    irreversible->revert_irreversible_state();
    solver.invalidate_factorization();
    if (broken == 1) {
      std::snprintf(buf, sizeof buf,
                    "load step %d/%d: the re-solve after breaking the single most critical bond did not "
                    "converge at load factor %.6g (",
                    k, n, lambda);
      return buf + r.reason + ")";  // the reason whole, however long
    }
    at_most = std::max<Index>(1, broken / 2);
    successes = 0;
    ++step.break_cutbacks;
    observer.resolve_failed(r.reason, broken, at_most);
  }
}
/// The first iterate of an attempt at load factor `next` from the converged x at `lambda`:
/// with loading.extrapolate, along the secant from (x_before, lambda_before) when there is one,
/// else the solver's tangent predictor; x itself otherwise. Held fragments stay where they are:
/// the secant would carry them on by the motion they had before they were cut loose.
void predict(VectorXd& trial, const VectorXd& x, const VectorXd& x_before, double lambda_before,
             double lambda, double next, const Loading& loading, Problem& problem, StepSolver& solver,
             StepReport& step) {
  if (loading.extrapolate && lambda_before >= 0.0 && lambda > lambda_before) {
    trial = ((next - lambda) / (lambda - lambda_before)) * (x - x_before);
    problem.hold_increment(trial);
    trial += x;
  } else {
    trial = x;
    if (loading.extrapolate)
      accumulate(step, solver.predict(trial, lambda));  // no secant: the solver's tangent
  }
}

/// After a failed attempt of `step` at load factor `next` (its cut-backs and `halvings` counted):
/// the load factor back at the converged `lambda`, and the factor dropped (it may belong to a
/// diverged iterate). Returns why the step has to stop instead of halving the increment, or "".
std::string after_failed_attempt(Problem& problem, StepSolver& solver, const Loading& loading,
                                 const StepReport& step, int halvings, int n, double lambda, double next,
                                 const std::string& last) {
  const int k = step.step;
  if (step.substeps + step.cutbacks > kMaxAttemptsPerStep) {
    char buf[224];
    std::snprintf(buf, sizeof buf,
                  "load step %d/%d stopped at load factor %.6g after %d sub-steps and %d cut-backs: the "
                  "increment keeps failing %d halvings deep (last attempt: ",
                  k, n, lambda, step.substeps, step.cutbacks, halvings);
    problem.set_load_factor(lambda);
    return buf + last + ")";  // the reason whole, however long
  }
  problem.set_load_factor(lambda);
  solver.invalidate_factorization();
  if (halvings > loading.max_cutbacks || !solver.cutback_helps()) {
    char buf[160];
    std::snprintf(buf, sizeof buf, "load step %d/%d did not converge at load factor %.6g after %d cut-backs "
                  "(last attempt: ", k, n, next, step.cutbacks - 1);
    return buf + last + ")";  // the reason whole, however long
  }
  return {};
}
}  // namespace

RunReport run_load_steps(Problem& problem, StepSolver& solver, VectorXd& x, const Loading& loading,
                         LoadSteppingObserver& observer, int steps_done) {
  RunReport run;
  run.steps_done = steps_done;
  const int n = loading.steps;
  const double nominal = 1.0 / n;
  double lambda = problem.load_factor();
  VectorXd trial, r_check;
  // The predictor's secant: the accepted state before the last one and its load factor (none
  // until two states are known: at the start, after a resume, after a cut-back).
  VectorXd x_before;
  double lambda_before = -1.0;
  for (int k = steps_done + 1; k <= n; ++k) {
    const double start = wall_seconds();
    const double target = static_cast<double>(k) / n;
    StepReport step;
    step.step = k;
    // Before the first checkpoint (a run from the unloaded state, step 1) no other run can
    // reach this step's state by another path (StepSolver::set_reproducible).
    solver.set_reproducible(steps_done > 0 || k > 1);
    double increment = target - lambda;
    int halvings = 0;  // current depth below the nominal increment
    // A ModelLimit (the model cannot follow the state: Problem::check_converged_state) stops the
    // run at the last converged state x; PartsOutgrown goes to the caller, which can grow the
    // parts and solve this step again from its last checkpoint.
    try {
      while (lambda < target - kReachedTarget * nominal) {
        if (!solver.prepared()) solver.prepare(x);  // tangent of the converged state
        const double next = std::min(lambda + increment, target);
        solver.set_last_load(k == n && next == target);  // and its re-solves after breaking
        problem.set_load_factor(next);
        observer.attempt_started(k, n, next, step.cutbacks);
        predict(trial, x, x_before, lambda_before, lambda, next, loading, problem, solver, step);
        const SolveReport r = solve_and_check(problem, solver, trial, r_check, observer, step);
        if (r.converged || r.accepted_unconverged) {
          x_before = x;
          lambda_before = lambda;
          accept(problem, x, trial, r, step);
          lambda = next;
          ++step.substeps;
          if (std::string why =
                  break_and_resolve(problem, solver, x, trial, r_check, loading, observer, step, n, lambda);
              !why.empty()) {
            run.message = std::move(why);
            return run;
          }
          if (halvings > 0) {  // grow back towards the nominal increment
            --halvings;
            increment *= 2.0;
          }
          continue;
        }
        ++step.cutbacks;
        ++halvings;
        if (std::string why =
                after_failed_attempt(problem, solver, loading, step, halvings, n, lambda, next, r.reason);
            !why.empty()) {
          run.message = std::move(why);
          return run;
        }
        lambda_before = -1.0;  // the retry starts from the converged state, not a prediction
        increment *= 0.5;
        observer.cut_back(r.reason, increment);
      }
    } catch (const PartsOutgrown&) {  // the caller re-cuts the parts and solves the step again
      problem.set_load_factor(lambda);
      throw;
    } catch (const ModelLimit& limit) {  // a check of a solve or re-solve: no smaller increment helps
      problem.set_load_factor(lambda);
      run.message = "load step " + std::to_string(k) + "/" + std::to_string(n) + ": " + limit.what();
      return run;
    }
    step.load_factor = lambda;
    step.wall_seconds = wall_seconds() - start;
    run.steps_done = k;
    observer.step_done(step, x);
  }
  run.completed = true;
  run.message = "completed";
  return run;
}

}  // namespace peristat
