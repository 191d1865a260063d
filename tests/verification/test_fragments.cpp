// Fragments (issue 15, part 4; docs/theory/failure.md "Fragments"): a particle that loses
// every bond is held where it is and taken out of the system, so that the rest of the body
// is still solved; before, its zero stiffness made every re-solve fail (exit 3).
#include <cmath>

#include <gtest/gtest.h>

#include "support/scenes.hpp"
#include "support/solve.hpp"

namespace peristat {
namespace {

TEST(Fragments, AParticleWithoutBondsIsHeldAndTheRestIsSolved) {
  // The edge-notched plate (40 x 20 particles, left edge held, right edge pulled 2e-5 m: below
  // the threshold, no bond breaks by itself).
  const Scene scene = test::scene_from_yaml(test::notch_yaml(2e-5, true));
  const Model model = discretise(scene);
  QuasiStaticProblem problem(model, problem_options(scene));
  const Particles& p = model.particles;
  // An interior particle far from the notch and the grips, moved by 10 dx: all its bonds are
  // stretched far beyond s_c (at least (10 - 3) / 3 - 1 = 1.3 for the longest, 3 dx), and
  // none other is.
  Index moved = -1;
  double nearest = 1.0;
  for (Index i = 0; i < p.size(); ++i)
    if (const double d = (p.position[i] - Vec2(0.03, 0.015)).norm(); !p.fictitious[i] && d < nearest) {
      nearest = d;
      moved = i;
    }
  ASSERT_LT(nearest, 1e-3);
  const Index fx = model.constraints.free_index[2 * moved];
  ASSERT_GE(fx, 0);
  VectorXd x = VectorXd::Zero(problem.n_unknowns());
  x[fx] = 1e-2;
  problem.set_load_factor(0.0);
  while (problem.advance_irreversible_state(x) > 0) problem.commit(x);
  const Index family = model.bonds.family_size(moved);
  EXPECT_EQ(problem.failure()->broken(), family) << "exactly the moved particle's bonds break";
  EXPECT_EQ(problem.fragment_particles(), 1);
  EXPECT_EQ(problem.fragments(), 1);

  // Load steps from this state: the tangent is regular, the particle stays where it was, and
  // the rest of the plate is in equilibrium.
  std::unique_ptr<LinearSolver> linear;
  const std::unique_ptr<StepSolver> solver = make_step_solver(scene, problem, linear);
  const RunReport run = run_load_steps(problem, *solver, x, scene.loading, {});
  ASSERT_TRUE(run.completed) << run.message;
  EXPECT_EQ(x[fx], 1e-2) << "the fragment is held where it was";
  VectorXd r;
  problem.evaluate(x, r, nullptr);
  EXPECT_LT(r.norm(), 1e-8 * problem.force_scale());
}

}  // namespace
}  // namespace peristat
