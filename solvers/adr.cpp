#include "solvers/adr.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <exception>
#include <span>
#include <limits>
#include <stdexcept>
#include <utility>

#include "core/clock.hpp"
#include "core/scope_exit.hpp"
#include "core/stop.hpp"

namespace peristat {

namespace {
/// Damping cap: below 2 so that the velocity factor (2 - c) / (2 + c) stays positive.
constexpr double kMaxDamping = 1.999;
/// Floor of the force scale and of the tolerance: no division by zero and a finite test
/// when every force is zero.
constexpr double kForceFloor = 1e-300;
/// Floor of the stiffness row sums relative to the largest: a row without stiffness still
/// gets a positive density (the update divides by it).
constexpr double kRowSumFloor = 1e-12;

/// An iteration count (long, like max_iterations) as the int the reports hold, clamped.
int clamp_to_int(long iteration) {
  return static_cast<int>(std::min<long>(iteration, std::numeric_limits<int>::max()));
}
}  // namespace

AdrSolver::AdrSolver(Problem& problem, const AdrOptions& options, PseudoVelocityInput* velocity,
                     UnknownShare share)
    : m_problem(problem), m_velocity(velocity), m_options(options), m_share(std::move(share)) {
  if (m_share.distributed() &&
      (static_cast<Index>(m_share.owned.size()) != problem.n_unknowns() || !m_share.exchange))
    throw std::logic_error("AdrSolver: the shared unknowns are not the problem's");
}

void AdrSolver::prepare(const VectorXd& x) {
  const ProblemTraits traits = m_problem.traits();
  if (m_have_density && traits.tangent_constant && m_structure == traits.structure_version) return;
  // Gershgorin: with Lambda_ii >= 1/4 sum_j |K_ij| every eigenvalue of Lambda^-1 K is at most
  // 4, the stability limit of the central difference with unit time step (Kilic and Madenci).
  if (m_K.size() == 0 || m_structure != traits.structure_version) {
    take(m_K, m_problem.make_tangent());
    m_structure = traits.structure_version;
  }
  m_problem.evaluate(x, m_r, &m_K);
  const Index n = m_problem.n_unknowns();
  VectorXd rows = VectorXd::Zero(n);
  for (Index col = 0; col < m_K.outerSize(); ++col)
    for (SparseMatrix::InnerIterator it(m_K, col); it; ++it) rows[it.row()] += std::abs(it.value());
  if (const PreconditionerSource* source = m_problem.preconditioner_source())
    source->add_stiffness_bound(rows);
  // Distributed, a rank's rows hold only its own unknowns' sums: the largest over the ranks.
  const double largest = m_share.distributed() ? m_share.ranks->max(rows.maxCoeff()) : rows.maxCoeff();
  m_density = 0.25 * m_options.density_factor * rows.cwiseMax(kRowSumFloor * largest);
  m_have_density = true;
}

double AdrSolver::residual_tolerance(double force_scale) const {
  return std::max(m_options.rtol * force_scale, kForceFloor);
}

double AdrSolver::measure(const VectorXd& x, bool damping, double& num, double& den) const {
  const Index n = x.size();
  if (!m_share.distributed()) {
    if (damping) {
      num = den = 0.0;
      for (Index i = 0; i < n; ++i) {
        const double xi2 = x[i] * x[i];
        den += xi2;
        if (m_v[i] != 0.0) num += xi2 * (m_r[i] - m_r_old[i]) / (m_density[i] * m_v[i]);
      }
    }
    return m_r.norm();
  }
  double sums[3] = {0.0, 0.0, 0.0};  // r.r, num, den
  for (Index i = 0; i < n; ++i) {
    if (!m_share.owned[static_cast<std::size_t>(i)]) continue;
    sums[0] += m_r[i] * m_r[i];
    if (!damping) continue;
    const double xi2 = x[i] * x[i];
    sums[2] += xi2;
    if (m_v[i] != 0.0) sums[1] += xi2 * (m_r[i] - m_r_old[i]) / (m_density[i] * m_v[i]);
  }
  m_share.ranks->sum_in_rank_order(std::span<double>(sums, damping ? 3 : 1));
  num = sums[1];
  den = sums[2];
  return std::sqrt(sums[0]);
}

void AdrSolver::share_reads(VectorXd& x) {
  if (!m_share.distributed()) return;
  if (!m_share.problem_imports_state) m_share.exchange->share_reads(x);
  if (m_velocity) m_share.exchange->share_reads(m_v);
}

void AdrSolver::take_step(VectorXd& x, double c) {
  // Left to decay on the entries of other ranks, the velocities would reach subnormal
  // numbers and slow the loop.
  const bool distributed = m_share.distributed();
  const Index n = x.size();
  for (Index i = 0; i < n; ++i) {
    if (distributed && !m_share.owned[static_cast<std::size_t>(i)]) continue;
    m_v[i] = ((2.0 - c) * m_v[i] - 2.0 * m_r[i] / m_density[i]) / (2.0 + c);
    x[i] += m_v[i];
  }
  share_reads(x);
}

Index AdrSolver::break_bonds(const VectorXd& x) {
  IrreversibleState* irreversible = m_problem.irreversible_state();
  const Index broken = irreversible->advance_irreversible_state(x, 0);
  // New faces may add contact pairs, stiffer than the bonds they replace: the density is
  // bounded again, or the central difference could lose its stability.
  if (broken > 0) {
    m_have_density = false;
    const bool rows_only = m_share.distributed();  // the tangent needs every row
    if (rows_only) m_problem.set_evaluation_mode(EvaluationMode::standard);
    prepare(x);
    if (rows_only) m_problem.set_evaluation_mode(EvaluationMode::own_rows_only);
  }
  return broken;
}

void AdrSolver::spent_budget(SolveReport& report, double relative) const {
  const AdrOptions& o = m_options;
  char buf[200];
  std::snprintf(buf, sizeof buf, "ADR budget of %ld iterations reached at relative residual %.3e (rtol %.1e)",
                o.max_iterations, relative, o.rtol);
  report.reason = buf;
  if (o.accept_on_budget) {
    report.accepted_unconverged = true;
    report.reason += "; state kept (on_budget: accept)";
  }
}

SolveReport AdrSolver::solve(VectorXd& x, IterationObserver* observer) {
  SolveReport report;
  const AdrOptions& o = m_options;
  const Index n = x.size();
  m_v.setZero(n);
  m_r_old.resize(n);
  if (m_velocity) m_velocity->set_velocity(m_v);

  // Distributed: the rank's rows only while relaxing, the whole residual again after (the
  // load stepping recomputes it from scratch, and checks, commits and writes from it).
  const bool distributed = m_share.distributed();
  if (distributed && !m_problem.set_evaluation_mode(EvaluationMode::own_rows_only))
    throw std::logic_error("AdrSolver: the problem cannot evaluate its own rows only");
  // Every unknown on every rank once the solve ends, however it ends.
  const ScopeExit whole_after([&] {
    if (!distributed) return;
    m_problem.set_evaluation_mode(EvaluationMode::standard);
    // (Unwinding: no collective call, which the other ranks may not be making.)
    if (std::uncaught_exceptions() > 0) return;
    m_share.exchange->share_all(x);
    if (m_velocity) m_share.exchange->share_all(m_v);
  });
  double num = 0.0, den = 0.0;  // the Rayleigh quotient's sums at x (measure())

  const bool breaking = breaks_while_solving();
  double t0 = wall_seconds();
  if (breaking) report.bonds_broken += break_bonds(x);
  m_problem.evaluate(x, m_r, nullptr);
  report.seconds_evaluate += wall_seconds() - t0;
  const auto tolerance = [&] { return residual_tolerance(m_problem.force_scale()); };
  const auto relative = [&](double norm) { return norm / std::max(m_problem.force_scale(), kForceFloor); };
  double norm = measure(x, false, num, den);
  // Breaking during the iterations, a state is converged only when a check at it breaks
  // nothing more (the bonds a round broke can change the criterion of others: a skew's
  // reference bond is replaced; `fraction` < 1 breaks part of them per round). That check
  // also leaves the reported criterion peak an intact bond's.
  const auto settled = [&] {
    if (!breaking) return true;
    const Index more = break_bonds(x);
    if (more == 0) return true;
    report.bonds_broken += more;
    m_problem.evaluate(x, m_r, nullptr);
    norm = measure(x, false, num, den);
    return false;
  };
  report.residuals.push_back(relative(norm));
  if (observer) observer->iteration_done(0, report.residuals.back(), 0.0, 0);
  if (norm <= tolerance() && settled()) {
    report.converged = true;
    report.reason = "converged";
    return report;
  }

  // Central differences with unit time step, from rest: v^{1/2} = F^0 / (2 Lambda), then
  // v^{n+1/2} = ((2 - c) v^{n-1/2} + 2 F^n / Lambda) / (2 + c), u^{n+1} = u^n + v^{n+1/2},
  // with F = -r and c from the local Rayleigh quotient (docs/theory/adr.md).
  m_v = -0.5 * m_r.cwiseQuotient(m_density);
  x += m_v;  // distributed: zero on other ranks' entries (their rows are zero here)
  share_reads(x);
  double c = 0.0;
  for (long it = 1; it <= o.max_iterations; ++it) {
    throw_if_stop_requested();  // the progress line comes only every report_every steps
    m_r_old.swap(m_r);
    if (m_velocity) m_velocity->set_velocity(m_v);
    t0 = wall_seconds();
    // The paper's explicit procedure: the bonds over the criterion at the new positions break
    // before their forces are computed, so a state that converges has none left over it.
    if (breaking) report.bonds_broken += break_bonds(x);
    m_problem.evaluate(x, m_r, nullptr);
    report.seconds_evaluate += wall_seconds() - t0;
    report.iterations = clamp_to_int(it);
    norm = measure(x, true, num, den);
    const bool done = norm <= tolerance();
    if (!std::isfinite(norm)) {
      report.reason = "ADR diverged (non-finite residual) at iteration " + std::to_string(it);
      return report;
    }
    if (done || it % o.report_every == 0 || it == o.max_iterations) {
      report.residuals.push_back(relative(norm));
      if (observer) observer->iteration_done(clamp_to_int(it), report.residuals.back(), c, 0);
    }
    if (done && settled()) {
      report.converged = true;
      report.reason = "converged";
      return report;
    }
    if (it == o.max_iterations) break;
    // Local stiffness K1_ii = (r_i^n - r_i^{n-1}) / (Lambda_ii v_i^{n-1/2}); damping
    // c = 2 sqrt(u.K1 u / u.u) (num / den, from measure()), zero when the quotient is not
    // positive.
    c = (num > 0.0 && den > 0.0) ? std::min(2.0 * std::sqrt(num / den), kMaxDamping) : 0.0;
    take_step(x, c);
  }
  spent_budget(report, relative(norm));
  return report;
}

}  // namespace peristat
