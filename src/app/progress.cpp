#include "app/progress.hpp"

#include <cstdio>
#include <string>

#include <omp.h>

#include "app/interrupt.hpp"
#include "app/step_recorder.hpp"

namespace peristat {

ProgressPrinter::ProgressPrinter(bool verbose, SolverKind solver, const QuasiStaticProblem& problem)
    : m_verbose(verbose), m_adr(solver == SolverKind::adr), m_problem(problem) {}

void ProgressPrinter::header(const Scene& scene, const ModelSize& size, double model_seconds,
                             const std::string& method) const {
  if (!m_verbose) return;
  std::printf("peristat: %s (%s)\n", scene.name.c_str(), scene.path.c_str());
  print_size(size);
  std::printf("  model built in %.2f s; %s, %d threads\n", model_seconds, method.c_str(),
              omp_get_max_threads());
  if (m_adr)
    std::printf("  ADR: rtol %.1e, budget %ld iterations per step (%s when exhausted)\n",
                scene.solver.adr.rtol, scene.solver.adr.max_iterations,
                scene.solver.adr.accept_on_budget ? "keep the state" : "stop");
  if (const ContactSystem* contact = m_problem.contact())
    std::printf(
        "  contact        %d candidate pairs (found in %.3f s), radius %g m, %s law, friction %g, "
        "%s enforcement\n",
        contact->counts().candidates, m_problem.contact_setup_seconds(), contact->law().radius,
        scene.contact.normal == NormalLaw::paper ? "paper" : "pair", contact->law().friction,
        std::string(to_string(scene.contact.enforcement)).c_str());
  if (const ContactSystem* contact = m_problem.contact(); contact && contact->augmentation_capped())
    std::printf(
        "  note: exact enforcement uses at most 10 x the eq 17 contact modulus as its augmentation "
        "stiffness (contact.stiffness sets the rate, not the answer; docs/theory/contact.md)\n");
}

void ProgressObserver::attempt_started(int k, int n, double lambda, int cutbacks) {
  throw_if_stop_requested();
  if (!m_printer.m_verbose) return;
  std::printf("step %d/%d  load factor %.6g%s\n", k, n, lambda, cutbacks ? "  (after cut-back)" : "");
  std::fflush(stdout);
}

void ProgressObserver::iteration_done(int it, double rel, double extra, int krylov) {
  throw_if_stop_requested();
  if (!m_printer.m_verbose) return;
  if (m_printer.m_adr)
    std::printf("  adr %9d  residual %.3e  damping %.4f", it, rel, extra);
  else if (it == 0)
    std::printf("  newton %2d  residual %.3e", it, rel);
  else
    std::printf("  newton %2d  residual %.3e  step %.3g", it, rel, extra);
  if (krylov > 0) std::printf("  krylov %d", krylov);
  if (const ContactSystem* contact = m_printer.m_problem.contact()) {
    const ContactCounts& c = contact->counts();
    std::printf("  contact open %d stick %d slip %d", c.open, c.stick, c.slip);
  }
  std::printf("\n");
  std::fflush(stdout);
}

void ProgressObserver::bonds_broke(Index broken, int resolve) {
  throw_if_stop_requested();
  // Net counts: a round whose re-solve failed is dropped (its bonds restored) and retried smaller.
  const long in_all = static_cast<long>(m_printer.m_problem.failure()->broken());
  if (resolve == 1) m_broken_before_this_load = in_all - static_cast<long>(broken);
  if (!m_printer.m_verbose) return;
  if (resolve < kRunningAfter)
    std::printf("  %ld bonds broke (%ld in all); re-solve %d at the same load\n", static_cast<long>(broken), in_all,
                resolve);
  else  // the crack runs at a fixed load: followed until it arrests or the body separates
    std::printf(
        "  crack running at load factor %.6g: %ld bonds broke, re-solve %d (%ld at this load, %ld in all)\n",
        m_printer.m_problem.load_factor(), static_cast<long>(broken), resolve,
        in_all - m_broken_before_this_load, in_all);
  std::fflush(stdout);
}

void ProgressObserver::resolve_failed(const std::string& reason, Index broken, Index next) {
  if (!m_printer.m_verbose) return;
  std::printf("  re-solve failed (%s): the %ld bonds are restored; retrying with the %ld most critical\n",
              reason.c_str(), static_cast<long>(broken), static_cast<long>(next));
  std::fflush(stdout);
}

void ProgressObserver::multipliers_updated(double violation, int update) {
  throw_if_stop_requested();
  if (!m_printer.m_verbose) return;
  std::printf(
      "  exact contact: largest violation %.3e of a pair's normal distance (closure, gap under load or "
      "stuck slip); multiplier update %d, "
      "solving again\n",
      violation, update);
  std::fflush(stdout);
}

void ProgressObserver::cut_back(const std::string& reason, double next) {
  if (m_printer.m_verbose) std::printf("  cut-back: %s; next increment %.4g\n", reason.c_str(), next);
}

void ProgressPrinter::step_done(const StepReport& s) const {
  if (!m_verbose) return;
  if (const ContactSystem* contact = m_problem.contact()) {
    const ContactCounts& c = contact->counts();
    std::printf(
        "  contact: %d open, %d stick, %d slip of %d pairs; active set changed in %d iterations; "
        "closest pair %.3g dx, largest closure %.3g dx%s\n",
        c.open, c.stick, c.slip, c.candidates, s.active_set_changes,
        contact->min_distance() / m_problem.model().spacing, contact->max_closure() / m_problem.model().spacing,
        s.multiplier_updates > 0 ? (", " + std::to_string(s.multiplier_updates) + " multiplier updates").c_str()
                                 : "");
  }
  if (const std::string warning = compliance_warning(m_problem, s); !warning.empty())
    std::printf("  WARNING: %s\n", warning.c_str());
  if (const BondFailure* failure = m_problem.failure())
    std::printf(
        "  failure: %ld bonds broke in this step (%d re-solves, %d halved after a failed re-solve), "
        "%ld in all; largest criterion ratio of an intact bond %.4f\n",
        static_cast<long>(s.bonds_broken), s.resolves, s.break_cutbacks,
        static_cast<long>(failure->broken()), failure->peak().ratio);
  if (m_adr) {
    std::printf("  %s: %d ADR iterations, relative residual %.3e; %.2f s (force evaluations %.2f s)\n",
                s.unconverged ? "NOT converged, kept (on_budget: accept)" : "converged", s.newton_iterations,
                s.final_residual, s.wall_seconds, s.seconds_evaluate);
  } else {
    const auto counted = [](int n, const char* noun) {
      return std::to_string(n) + " " + noun + (n == 1 ? "" : "s");
    };
    std::printf("  converged: %s, %s, %s; %.2f s (assembly %.2f%s, factorisation %.2f, solves %.2f)\n",
                counted(s.newton_iterations, "Newton iteration").c_str(),
                counted(s.factorizations, "factorisation").c_str(),
                counted(s.linear_iterations, "Krylov iteration").c_str(), s.wall_seconds, s.seconds_evaluate,
                m_problem.contact() ? " incl. contact" : "", s.seconds_factorize, s.seconds_solve);
  }
}

}  // namespace peristat
