// The wiring from a validated Scene to the objects that solve it, shared by `peristat run`,
// `check` and the tests: each component takes its own options.
#pragma once

#include <memory>

#include "assembly/quasi_static.hpp"
#include "scene/scene.hpp"
#include "solvers/linear/linear_solver.hpp"
#include "solvers/step_solver.hpp"

namespace peristat {

/// What the problem models, from the scene.
ProblemOptions problem_options(const Scene& scene);

/// The step solver the scene asks for (Newton or ADR); `linear` receives Newton's linear
/// solver (it must outlive the step solver) and stays empty for ADR.
std::unique_ptr<StepSolver> make_step_solver(const Scene& scene, QuasiStaticProblem& problem,
                                             std::unique_ptr<LinearSolver>& linear);

}  // namespace peristat
