#include "app/setup.hpp"

#include "solvers/adr.hpp"
#include "solvers/newton.hpp"

namespace peristat {

ProblemOptions problem_options(const Scene& scene) {
  return {scene.contact, scene.failure, scene.solver.bond_preconditioner, scene.discretization.surface_correction};
}

namespace {

/// Each unknown's particle and direction, and the particles' positions (LinearSolver's hint).
UnknownLayout unknown_layout(const Model& model, Index n_unknowns) {
  const std::vector<Index>& free = model.constraints.free_index;
  UnknownLayout layout;
  layout.component.resize(n_unknowns);
  for (Index c = 0; c < static_cast<Index>(free.size()); ++c)
    if (free[c] >= 0) layout.component[free[c]] = c;
  layout.x.reserve(model.particles.size());
  layout.y.reserve(model.particles.size());
  for (const Vec2& X : model.particles.position) {
    layout.x.push_back(X.x());
    layout.y.push_back(X.y());
  }
  return layout;
}

}  // namespace

std::unique_ptr<StepSolver> make_step_solver(const Scene& scene, QuasiStaticProblem& problem,
                                             std::unique_ptr<LinearSolver>& linear) {
  if (scene.solver.type == SolverKind::adr)
    return std::make_unique<AdrSolver>(problem, scene.solver.adr, problem.pseudo_velocity_input());
  linear = make_linear_solver(scene.solver.linear);
  if (linear->needs_unknown_layout()) linear->set_unknown_layout(unknown_layout(problem.model(), problem.n_unknowns()));
  return std::make_unique<NewtonSolver>(problem, *linear, scene.solver.newton);
}

}  // namespace peristat
