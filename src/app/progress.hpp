// What `peristat run` prints while it runs (README.md, "Using it": load step k/N and the
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
  /// The load-stepping callbacks that print (and check for a pending signal); on_step is left
  /// to the caller.
  LoadSteppingCallbacks callbacks() const;
  /// The end-of-step lines: contact counts, bonds broken, iterations and timings.
  void step_done(const StepReport& step) const;

 private:
  bool m_verbose;
  bool m_adr;
  const QuasiStaticProblem& m_problem;
};

}  // namespace peristat
