// What `peristat run` prints while it runs (docs/guide/scene.md, "The command line": load step k/N and the
// residuals as they go); --quiet silences all of it. Every method checks for Ctrl-C first
// where the original run loop did, so a signal stops the run at the next iterate.
#pragma once

#include <string>

#include "app/model_size.hpp"
#include "scene/scene.hpp"
#include "solvers/load_stepping.hpp"

namespace peristat {

class ProgressPrinter {
 public:
  ProgressPrinter(bool verbose, SolverKind solver, const QuasiStaticProblem& problem);

  /// The run's header: scene, model size, method, threads, ADR budget, contact candidates.
  void header(const Scene& scene, const ModelSize& size, double model_seconds,
              const std::string& method) const;
  /// The end-of-step lines: contact counts, bonds broken, iterations and timings.
  void step_done(const StepReport& step) const;

 private:
  friend class ProgressObserver;
  bool m_verbose;
  bool m_adr;
  const QuasiStaticProblem& m_problem;
};

/// The load-stepping observer that prints (and checks for a pending signal) what a
/// ProgressPrinter says; step_done is left to a derived class.
class ProgressObserver : public LoadSteppingObserver {
 public:
  explicit ProgressObserver(const ProgressPrinter& printer) : m_printer(printer) {}

  void attempt_started(int k, int n, double lambda, int cutbacks) override;
  void iteration_done(int it, double rel, double extra, int krylov) override;
  void bonds_broke(Index broken, int resolve) override;
  void resolve_failed(const std::string& reason, Index broken, Index next) override;
  void multipliers_updated(double violation, int update) override;
  void cut_back(const std::string& reason, double next) override;

 private:
  /// From this re-solve at one load on, the progress line says that the crack runs.
  static constexpr int kRunningAfter = 3;
  const ProgressPrinter& m_printer;
  long m_broken_before_this_load = 0;  ///< bonds broken before the first re-solve at the current load
};

}  // namespace peristat
