#include "support/solve.hpp"

#include <utility>

#include <Eigen/Dense>

#include "app/linear_solvers.hpp"
#include "app/setup.hpp"
#include "core/clock.hpp"
#include "support/forwarding_solver.hpp"
#include "support/scenes.hpp"
#include "support/step_log.hpp"

namespace peristat::test {

std::unique_ptr<Solved> solve_scene(const std::string& yaml) {
  return solve_parsed(scene_from_yaml(yaml));
}

std::unique_ptr<Solved> solve_case(const std::string& name, const std::vector<std::string>& overrides) {
  std::vector<Override> o;
  for (const std::string& a : overrides) o.push_back(parse_override(a));
  return solve_parsed(parse_scene(std::string(PERISTAT_SOURCE_DIR) + "/cases/" + name + "/scene.yaml", o));
}

namespace {
/// Tells the solver that every solve's path must be reproducible, the first step's too.
class AlwaysReproducible final : public ForwardingStepSolver {
 public:
  explicit AlwaysReproducible(StepSolver& inner) : ForwardingStepSolver(inner) {
    m_inner.set_reproducible(true);
  }
  void set_reproducible(bool) override {}
};
}  // namespace

std::unique_ptr<Solved> solve_parsed(Scene scene, bool always_reproducible) {
  auto s = std::make_unique<Solved>();
  s->scene = std::move(scene);
  register_linear_solvers();  // as main() does
  // solver.linear: auto resolved as `peristat run` does, before the problem is built.
  resolve_linear_solver(s->scene, 1);
  s->model = discretise(s->scene);
  s->problem = std::make_unique<QuasiStaticProblem>(s->model, problem_options(s->scene));
  std::unique_ptr<LinearSolver> linear;
  const std::unique_ptr<StepSolver> solver = make_step_solver(s->scene, *s->problem, linear);
  s->x = VectorXd::Zero(s->problem->n_unknowns());
  s->problem->set_load_factor(0.0);
  StepLog log;
  const double t0 = wall_seconds();
  if (always_reproducible) {
    AlwaysReproducible reproducible(*solver);
    s->run = run_load_steps(*s->problem, reproducible, s->x, s->scene.loading, log);
  } else {
    s->run = run_load_steps(*s->problem, *solver, s->x, s->scene.loading, log);
  }
  s->seconds = wall_seconds() - t0;
  s->steps = std::move(log.steps);
  // The solver's last evaluation was at the converged x, so the problem's state (stresses,
  // contact forces and pair states) is that of the solution. Evaluating again here would
  // see the committed slip and report slipping pairs as sticking at the limit.
  s->problem->expand(s->x, s->u);
  return s;
}

Eigen::Vector3d fit_affine(const Solved& s, int component, const Vec2& lo, const Vec2& hi) {
  const Particles& p = s.model.particles;
  std::vector<Index> pick;
  for (Index i = 0; i < p.size(); ++i) {
    const Vec2& X = p.position[i];
    if (!p.fictitious[i] && (X.array() >= lo.array()).all() && (X.array() <= hi.array()).all())
      pick.push_back(i);
  }
  Eigen::MatrixXd A(pick.size(), 3);
  VectorXd b(pick.size());
  for (std::size_t k = 0; k < pick.size(); ++k) {
    A.row(k) << 1.0, p.position[pick[k]].x(), p.position[pick[k]].y();
    b[k] = s.u[2 * pick[k] + component];
  }
  return A.colPivHouseholderQr().solve(b);
}

}  // namespace peristat::test
