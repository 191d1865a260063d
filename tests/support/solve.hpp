// Solving a scene in-process for tests: the same pieces `peristat run` uses.
#pragma once

#include <memory>
#include <vector>

#include "app/setup.hpp"
#include "assembly/quasi_static.hpp"
#include "solvers/adr.hpp"
#include "solvers/linear/linear_solver.hpp"
#include "solvers/load_stepping.hpp"
#include "solvers/newton.hpp"

namespace peristat::test {

struct Solved {
  Scene scene;
  Model model;
  std::unique_ptr<QuasiStaticProblem> problem;
  VectorXd x;  ///< unknowns at the end
  VectorXd u;  ///< full displacement (2N)
  std::vector<StepReport> steps;
  RunReport run;
  double seconds = 0.0;  ///< wall time of the load steps
  long iterations() const {
    long n = 0;
    for (const StepReport& r : steps) n += r.newton_iterations;
    return n;
  }
};

/// Parses, discretises and solves with the scene's own solver options (solver.type newton or adr).
std::unique_ptr<Solved> solve_scene(const std::string& yaml);
/// The same for a parsed scene (e.g. a case file with --set overrides). With
/// `always_reproducible` the step solver is told that every solve's path must be reproducible
/// (StepSolver::set_reproducible), the first step's too.
std::unique_ptr<Solved> solve_parsed(Scene scene, bool always_reproducible = false);
/// A case of cases/<name>/scene.yaml with `--set` style overrides ("key=value").
std::unique_ptr<Solved> solve_case(const std::string& name, const std::vector<std::string>& overrides);

/// Least-squares affine fit u_c = a0 + a1 X + a2 Y of component c over the real particles
/// whose reference position lies in [lo, hi]; returns (a0, a1, a2).
Eigen::Vector3d fit_affine(const Solved& s, int component, const Vec2& lo, const Vec2& hi);

}  // namespace peristat::test
