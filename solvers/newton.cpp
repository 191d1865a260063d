#include "solvers/newton.hpp"

#include <bit>
#include <cmath>
#include <cstring>
#include <limits>

#include "core/clock.hpp"
#include "core/scope_exit.hpp"

namespace peristat {

namespace {
/// Floor of the force scale and of ||x||: keeps the relative measures finite at zero.
constexpr double kTiny = std::numeric_limits<double>::min();
/// Armijo sufficient decrease, the customary value (Dennis and Schnabel): a step must achieve
/// 1e-4 of the decrease alpha ||r|| that the linear model predicts, i.e. almost any decrease.
constexpr double kArmijo = 1e-4;
/// Backtracking factor: the step length is halved (1, 1/2, 1/4, ...) until accepted.
constexpr double kBacktrack = 0.5;
/// Largest forcing term of the inexact Newton iterations (docs/theory/newton.md, "Inexact
/// Newton"): a Krylov solve stops at no more than this relative residual. Measured on cases
/// 4.1 and 4.3 (docs/performance.md, "Inexact Newton and the load-step predictor"): 0.1 and
/// 1e-2 let the contact active set wander (4.1 step 1: 18 and 13 Newton iterations against 10),
/// 1e-3 keeps the fixed-tolerance iteration count with a third of the Krylov iterations, 1e-4
/// is slower again.
constexpr double kForcingMax = 1e-3;
/// The Euler predictor's central-difference step in the load factor, as a fraction of the
/// increment: small enough that the prescribed components move far less than a spacing (the
/// difference is then linear to about 1e-6 even where the whole increment is a spacing, as
/// at the grips of a 700 x 700 plate), large enough to keep 13 digits of the difference.
constexpr double kPredictorStep = 1e-3;
/// Loosest last solve where the path need not be reproducible. The Kelley term 0.5 tol/||r||
/// exceeds it only when ||r|| is already below the tolerance and Newton goes on for the
/// increment test (`newton.stol`): a solve allowed to stop at 1 or above would return no step.
constexpr double kLastSolveMax = 0.5;

/// A 64-bit fingerprint of x's bits (every entry; a multiply-rotate mix), to tell that the
/// predictor is given the state prepare() evaluated.
std::uint64_t bits_fingerprint(const VectorXd& x) {
  std::uint64_t h = 0x9E3779B97F4A7C15ULL ^ static_cast<std::uint64_t>(x.size());
  for (Index k = 0; k < x.size(); ++k) {
    std::uint64_t bits;
    std::memcpy(&bits, &x[k], sizeof bits);
    h = std::rotl(h ^ bits, 27) * 0x100000001B3ULL + 0x632BE59BD9B4E019ULL;
  }
  return h;
}
}  // namespace

NewtonSolver::NewtonSolver(Problem& problem, LinearSolver& linear, const NewtonOptions& options)
    : m_problem(problem),
      m_linear(linear),
      m_options(options),
      m_K(problem.make_tangent()),
      m_structure(problem.traits().structure_version) {}

void NewtonSolver::follow_structure() {
  const std::uint64_t structure = m_problem.traits().structure_version;
  if (structure == m_structure) return;
  m_structure = structure;
  take(m_K, m_problem.make_tangent());
  m_analyzed = m_unsymmetric_analyzed = false;
  m_have_factor = false;
  m_factored = nullptr;
}

bool NewtonSolver::reuse_factor() const {
  return m_have_factor && (m_problem.traits().tangent_constant || m_options.tangent == TangentKind::initial);
}

LinearSolver& NewtonSolver::select_solver() {
  if (m_K_symmetric || !m_linear.traits().needs_symmetric) return m_linear;
  if (!m_unsymmetric) {  // first slip with a symmetric-only solver: UMFPACK takes over
    LinearOptions lu;
    lu.type = LinearSolverKind::umfpack;
    m_unsymmetric = make_linear_solver(lu);
  }
  return *m_unsymmetric;
}

void NewtonSolver::factorize(SolveReport& report) {
  const double t0 = wall_seconds();
  LinearSolver& lin = select_solver();  // which asks LinearSetup::system for P when it needs it
  bool& analyzed = &lin == &m_linear ? m_analyzed : m_unsymmetric_analyzed;
  if (!analyzed) {
    lin.analyzePattern(m_K);
    analyzed = true;
  }
  lin.factorize(m_K);
  m_factored = &lin;
  m_factor_state = m_problem.traits().state_signature;  // of the evaluation m_K comes from
  m_have_factor = lin.info() == Eigen::Success;
  report.seconds_factorize += wall_seconds() - t0;
}

void NewtonSolver::solve_linear(LinearSolver& lin, double rtol, SolveReport& report, double t0) {
  const double setup0 = lin.stats().setup_seconds;
  lin.configure({m_K_symmetric, rtol, m_problem.traits().preconditioner_state});
  m_rhs = -m_r;  // into kept storage: a temporary of the unknowns' size is an mmap per solve
  lin.solve(m_rhs, m_dx);
  // Held unknowns (fragments) move by exactly nothing: their rows are decoupled, but a
  // preconditioner that mixes rows (an AMG hierarchy built before the fragment was cut loose)
  // leaves round-off there, which a fragment's stretched bonds turn into energy no force
  // accounts for (docs/theory/failure.md, "Fragments").
  m_problem.hold_increment(m_dx);
  const double setup = lin.stats().setup_seconds - setup0;  // a deferred set-up counts as one
  report.seconds_factorize += setup;
  report.seconds_solve += wall_seconds() - t0 - setup;
}

long NewtonSolver::factorizations() const {
  return m_linear.stats().factorizations + (m_unsymmetric ? m_unsymmetric->stats().factorizations : 0);
}

void NewtonSolver::evaluate(const VectorXd& x, VectorXd& r, bool tangent) {
  m_problem.evaluate(x, r, tangent ? &m_K : nullptr);
  if (!tangent) return;
  m_K_symmetric = m_problem.traits().tangent_symmetric;
  m_tangent_skipped = false;
}

void NewtonSolver::prepare(const VectorXd& x) {
  follow_structure();
  const long f0 = factorizations();
  const double t0 = wall_seconds();
  evaluate(x, m_r, true);
  m_prepared_r = {true, m_problem.load_factor(), m_problem.traits().preconditioner_state,
                  bits_fingerprint(x)};
  m_pending.seconds_evaluate += wall_seconds() - t0;
  factorize(m_pending);
  m_pending.factorizations += static_cast<int>(factorizations() - f0);
}

SolveReport NewtonSolver::solve(VectorXd& x, IterationObserver* observer) {
  follow_structure();
  SolveReport report = m_pending;
  m_pending = SolveReport{};
  const long f0 = factorizations();
  report = solve_iterations(x, observer, std::move(report));
  report.factorizations += static_cast<int>(factorizations() - f0);
  return report;
}

SolveReport NewtonSolver::predict(VectorXd& x, double from) {
  SolveReport report;
  const double to = m_problem.load_factor();
  if (!prepared() || m_factored == nullptr || to == from) return report;
  double t0 = wall_seconds();
  // r(x; from) is prepare()'s when nothing moved since (the first attempt of a step): one
  // residual fewer, the same bits. Not with touching pairs closed (below).
  const bool as_prepared = residual_is_prepared(x, from);
  m_prepared_r.valid = false;
  const double h = kPredictorStep * (to - from);
  m_problem.set_load_factor(from + h);
  m_problem.evaluate(x, m_trial_r, nullptr);
  m_problem.set_load_factor(from - h);
  m_problem.evaluate(x, m_dx, nullptr);
  m_trial_r -= m_dx;
  m_trial_r *= 0.5 / kPredictorStep;  // dr/dlambda (to - from)
  m_problem.set_load_factor(from);
  // The tangent with touching contact pairs closed and stuck: an increment that pushes bodies
  // together is predicted with them in contact, not through each other (case 4.1, step 1:
  // 11 -> 5 Newton iterations). It replaces the factor when it differs from it.
  const bool closes = !reuse_factor() && m_problem.set_evaluation_mode(EvaluationMode::touching_closed);
  if (closes || !as_prepared) {
    const ScopeExit reopen([&] {
      if (closes) m_problem.set_evaluation_mode(EvaluationMode::standard);
    });
    evaluate(x, m_r, closes);
  }
  m_r += m_trial_r;  // the linearised residual at `to`
  m_problem.set_load_factor(to);
  report.seconds_evaluate += wall_seconds() - t0;
  const long f0 = factorizations();  // set-ups here and, deferred, in the solve below
  if (closes && m_problem.traits().state_signature != m_factor_state) {
    select_solver().renew_preconditioner();  // the kept one was built without these pairs
    factorize(report);
    if (!m_have_factor) {
      report.factorizations += static_cast<int>(factorizations() - f0);
      return report;
    }
  }

  t0 = wall_seconds();
  LinearSolver& lin = *m_factored;
  const double rtol = m_options.adaptive_forcing && lin.traits().iterative ? kForcingMax : 0.0;
  m_dx.setZero(m_r.size());
  solve_linear(lin, rtol, report, t0);
  report.factorizations += static_cast<int>(factorizations() - f0);
  report.linear_iterations += lin.stats().iterations;
  report.predictor_solves = 1;
  if (lin.info() == Eigen::Success && m_problem.unknowns().all_finite(m_dx)) x += m_dx;
  return report;
}

double NewtonSolver::forcing_term(int it, double norm, double previous_norm, double previous_eta) const {
  // Eisenstat & Walker (1996), choice 2 (gamma 0.9, alpha 2) with their safeguard against a
  // sudden drop, capped at kForcingMax; then no more accuracy than the Newton tolerance asks
  // of this step (Kelley 1995, eq. 6.20: 0.5 tol / ||r||). Where the path must be
  // reproducible (set_reproducible), never looser than kForcingMax: a last solve as loose as
  // the tolerance allows (0.1-0.5) leaves the converged state anywhere inside the tolerance,
  // and a resumed run, which reaches it by another path, 3e-10 from the uninterrupted run
  // instead of 1e-17 (measured on case 4.4, 2026-11-27). Before the first checkpoint every
  // run takes the same path, and the last solve may stop as soon as the tolerance allows.
  // The solver keeps its configured rtol as the floor. The first iteration of a solve has no
  // ratio: kForcingMax.
  double eta = kForcingMax;
  if (it > 1 && previous_norm > 0.0) {
    const double ratio = norm / previous_norm;
    eta = 0.9 * ratio * ratio;
    const double safeguard = 0.9 * previous_eta * previous_eta;
    if (safeguard > 0.1) eta = std::max(eta, safeguard);
  }
  eta = std::min(eta, kForcingMax);
  const double kelley = 0.5 * residual_tolerance(m_problem.force_scale()) / norm;
  if (!m_reproducible) return std::max(eta, std::min(kelley, kLastSolveMax));
  return std::min(kForcingMax, std::max(eta, kelley));
}

double NewtonSolver::residual_tolerance(double force_scale) const {
  return std::max(m_options.rtol * force_scale, m_options.atol);
}

double NewtonSolver::relative(double norm) const { return norm / std::max(m_problem.force_scale(), kTiny); }

bool NewtonSolver::converged(double norm) const { return norm <= residual_tolerance(m_problem.force_scale()); }

bool NewtonSolver::residual_is_prepared(const VectorXd& x, double load_factor) const {
  return m_prepared_r.valid && m_prepared_r.load_factor == load_factor &&
         m_prepared_r.problem_state == m_problem.traits().preconditioner_state &&
         m_prepared_r.x_bits == bits_fingerprint(x);
}

double NewtonSolver::evaluate_first(const VectorXd& x, bool& use_existing, SolveReport& report) {
  double t0 = wall_seconds();
  // A tangent left out at the last converged state (set_last_load) is evaluated here, with
  // the factor kept: a re-solve at the same load (the contact multipliers updated) then steps
  // with the tangent at its first iterate.
  const bool assemble0 = !(reuse_factor() || use_existing) || (m_tangent_skipped && !reuse_factor());
  // A re-solve after breaking starts where prepare() evaluated residual and tangent: its
  // residual is m_r's bits already (a residual-only evaluation gives the same bits).
  const bool prepared_r = residual_is_prepared(x, m_problem.load_factor());
  m_prepared_r.valid = false;  // m_r is the solve's from here
  if (assemble0 || !prepared_r) evaluate(x, m_r, assemble0);
  report.seconds_evaluate += wall_seconds() - t0;
  if (use_existing && !reuse_factor() && m_problem.traits().state_signature != m_factor_state) {
    // The first iterate's contact active set is not the one the factor was built with (the
    // predictor closed or opened pairs): that factor would step as if they had not, so the
    // tangent is evaluated here instead (case 4.3, step 1: 8 -> 5 Newton iterations).
    t0 = wall_seconds();
    evaluate(x, m_r, true);
    report.seconds_evaluate += wall_seconds() - t0;
    use_existing = false;
  }
  return m_problem.unknowns().norm(m_r);
}

bool NewtonSolver::expect_converged(const LinearSolver& lin, double norm, double previous_norm) const {
  // Only Krylov solves estimate their residual; an increment test (newton.stol) needs the
  // step, and a constant tangent is not evaluated anyway.
  if (!m_last_load || !lin.traits().iterative || m_options.stol > 0.0 || reuse_factor() ||
      previous_norm <= 0.0)
    return false;
  // The linear model's residual, and Newton's quadratic term from the last two residuals
  // (||r+|| ~ C ||r||^2 with C = ||r|| / ||r-||^2), each within the tolerance.
  const double tolerance = residual_tolerance(m_problem.force_scale());
  const double ratio = norm / previous_norm;
  return lin.stats().error * norm <= tolerance && ratio * ratio * norm <= tolerance;
}

bool NewtonSolver::line_search(const VectorXd& x, double& norm, double& alpha, bool expect_converged,
                               SolveReport& report) {
  // Backtracking: accept alpha when ||r(x + alpha dx)|| <= (1 - kArmijo alpha) ||r(x)||.
  const NewtonOptions& o = m_options;
  alpha = 1.0;
  for (int ls = 0;; ++ls) {
    m_trial = x + alpha * m_dx;
    double t0 = wall_seconds();
    const bool tangent = !reuse_factor() && !(expect_converged && ls == 0);
    evaluate(m_trial, m_trial_r, tangent);
    report.seconds_evaluate += wall_seconds() - t0;
    const double trial_norm = m_problem.unknowns().norm(m_trial_r);
    const bool accept =
        !o.line_search || converged(trial_norm) || trial_norm <= (1.0 - kArmijo * alpha) * norm;
    if (accept && std::isfinite(trial_norm)) {
      norm = trial_norm;
      if (tangent || reuse_factor()) return true;
      if (converged(trial_norm)) {  // the converged state: its tangent goes unused
        m_tangent_skipped = true;
        return true;
      }
      t0 = wall_seconds();  // not converged after all: the next iteration needs the tangent
      evaluate(m_trial, m_trial_r, true);
      report.seconds_evaluate += wall_seconds() - t0;
      return true;
    }
    if (ls >= o.line_search_max) {
      report.reason = "line search failed to reduce the residual (relative " +
                      std::to_string(relative(trial_norm)) + ")";
      return false;
    }
    alpha *= kBacktrack;
  }
}

SolveReport NewtonSolver::solve_iterations(VectorXd& x, IterationObserver* observer, SolveReport report) {
  // Iteration 1 uses the factor of the last converged state when there is one.
  bool use_existing = m_have_factor;
  const NewtonOptions& o = m_options;
  double norm = evaluate_first(x, use_existing, report);
  report.residuals.push_back(relative(norm));
  if (observer) observer->iteration_done(0, report.residuals.back(), 0.0, 0);
  // Discrete states (contact active set) of the accepted iterates, to count changes and
  // to detect a cycle between two states.
  std::uint64_t state[3] = {m_problem.traits().state_signature, 0, 0};
  int two_cycles = 0;
  double previous_norm = 0.0, eta = kForcingMax;  // the last iteration's residual and forcing term

  for (int it = 1;; ++it) {
    if (!std::isfinite(norm)) {
      report.reason = "the residual is not finite";
      return report;
    }
    const bool increment_ok =
        o.stol <= 0.0 || report.increments.empty() || report.increments.back() <= o.stol;
    if (converged(norm) && increment_ok) {
      report.converged = true;
      report.reason = "converged";
      return report;
    }
    if (it > o.max_iterations) {
      report.reason = "no convergence in " + std::to_string(o.max_iterations) + " iterations";
      return report;
    }
    if (two_cycles >= 3) {
      report.reason = "the contact active set cycles between two states";
      return report;
    }
    if (!reuse_factor() && !use_existing) {
      factorize(report);
      if (!m_have_factor) {
        report.reason = "factorisation failed: " + describe(m_factored->info());
        return report;
      }
    }
    const double t0 = wall_seconds();
    m_dx.setZero(m_r.size());
    LinearSolver& lin = m_factored ? *m_factored : m_linear;
    const bool iterative = lin.traits().iterative;
    if (o.adaptive_forcing && iterative) eta = forcing_term(it, norm, previous_norm, eta);
    solve_linear(lin, o.adaptive_forcing && iterative ? eta : 0.0, report, t0);
    const int krylov = iterative ? lin.stats().iterations : 0;
    report.linear_iterations += lin.stats().iterations;
    ++report.iterations;
    use_existing = false;
    if (lin.info() != Eigen::Success || !m_problem.unknowns().all_finite(m_dx)) {
      report.reason = "linear solve failed: " + describe(lin.info());
      return report;
    }

    const double norm_before = norm;
    double alpha = 1.0;
    if (!line_search(x, norm, alpha, expect_converged(lin, norm, previous_norm), report)) return report;
    x.swap(m_trial);
    m_r.swap(m_trial_r);
    previous_norm = norm_before;
    state[2] = state[1];
    state[1] = state[0];
    state[0] = m_problem.traits().state_signature;
    if (state[0] != state[1]) {
      ++report.active_set_changes;
      if (it >= 2 && state[0] == state[2]) ++two_cycles;
    }
    const UnknownSpace unknowns = m_problem.unknowns();
    report.increments.push_back(alpha * unknowns.norm(m_dx) / std::max(unknowns.norm(x), kTiny));
    report.residuals.push_back(relative(norm));
    if (observer) observer->iteration_done(it, report.residuals.back(), alpha, krylov);
  }
}

}  // namespace peristat
