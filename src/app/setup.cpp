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
  const Model& model = problem.model();
  const std::vector<Index>& free = model.constraints.free_index;
  UnknownLayout layout;
  layout.component.resize(problem.n_unknowns());
  for (Index c = 0; c < static_cast<Index>(free.size()); ++c)
    if (free[c] >= 0) layout.component[free[c]] = c;
  layout.x.reserve(model.particles.size());
  layout.y.reserve(model.particles.size());
  for (const Vec2& X : model.particles.position) {
    layout.x.push_back(X.x());
    layout.y.push_back(X.y());
  }
  linear->set_unknown_layout(layout);
  return std::make_unique<NewtonSolver>(problem, *linear, scene.solver.newton);
}

}  // namespace peristat
