#include "app/setup.hpp"

#include "solvers/adr.hpp"
#include "solvers/newton.hpp"

namespace peristat {

ProblemOptions problem_options(const Scene& scene) {
  return {scene.contact, scene.failure, scene.solver.bond_preconditioner, scene.discretization.surface_correction};
}

std::unique_ptr<StepSolver> make_step_solver(const Scene& scene, QuasiStaticProblem& problem,
                                             std::unique_ptr<LinearSolver>& linear) {
  if (scene.solver.type == SolverKind::adr)
    return std::make_unique<AdrSolver>(problem, scene.solver.adr, problem.pseudo_velocity_input());
  linear = make_linear_solver(scene.solver.linear);
  return std::make_unique<NewtonSolver>(problem, *linear, scene.solver.newton);
}

}  // namespace peristat
