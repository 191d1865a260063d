// Fragments (issue 15, part 4; docs/theory/failure.md "Fragments"): a particle that loses
// every bond is held where it is and taken out of the system, so that the rest of the body
// is still solved; before, its zero stiffness made every re-solve fail (exit 3).
#include <cmath>
#include <sstream>

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
  LoadSteppingObserver quiet;
  const RunReport run = run_load_steps(problem, *solver, x, scene.loading, quiet);
  ASSERT_TRUE(run.completed) << run.message;
  EXPECT_EQ(x[fx], 1e-2) << "the fragment is held where it was";
  VectorXd r;
  problem.evaluate(x, r, nullptr);
  EXPECT_LT(r.norm(), 1e-8 * problem.force_scale());
}

// A held fragment's own bonds neither break nor count for the criterion's peak: where a
// fragment is held is where it was cut loose, which the equations do not determine (a piece
// that hung by one bond before: serial and two-rank runs held one of case 4.4 up to 6 mm
// apart), so a bond of it over the criterion says nothing about the material. Two neighbouring
// interior particles of the notched plate are moved by 10 dx together: their bonds to the
// rest break and the pair between them, unstretched, stays: one fragment of two particles.
// Then one of them is moved 2 dx further along the pair: its stretch is 2, far over s_c
// (G_c = 10 J/m^2: s_c = 0.0021), and no other bond is stretched. Without the rule the pair
// breaks.
TEST(Fragments, AHeldFragmentsBondsDoNotBreak) {
  const Scene scene = test::scene_from_yaml(test::notch_yaml(2e-5, true));
  const Model model = discretise(scene);
  QuasiStaticProblem problem(model, problem_options(scene));
  const Particles& p = model.particles;
  const auto nearest_to = [&](Vec2 at) {
    Index best = -1;
    for (Index i = 0; i < p.size(); ++i)
      if (!p.fictitious[i] && (best < 0 || (p.position[i] - at).norm() < (p.position[best] - at).norm()))
        best = i;
    return best;
  };
  const Index a = nearest_to(Vec2(0.03, 0.015)), b = nearest_to(Vec2(0.031, 0.015));
  ASSERT_NEAR((p.position[b] - p.position[a]).norm(), 1e-3, 1e-12) << "neighbours along x";
  const Index ax = model.constraints.free_index[2 * a], bx = model.constraints.free_index[2 * b];
  ASSERT_GE(ax, 0);
  ASSERT_GE(bx, 0);
  VectorXd x = VectorXd::Zero(problem.n_unknowns());
  x[ax] = x[bx] = 1e-2;
  problem.set_load_factor(0.0);
  while (problem.advance_irreversible_state(x) > 0) problem.commit(x);
  const Index broken = problem.failure()->broken();
  EXPECT_EQ(broken, model.bonds.family_size(a) + model.bonds.family_size(b) - 2)
      << "every bond of the two but the one between them";
  ASSERT_EQ(problem.fragments(), 1);
  ASSERT_EQ(problem.fragment_particles(), 2);

  x[bx] += 2e-3;  // the pair's stretch: 2
  EXPECT_EQ(problem.advance_irreversible_state(x), 0) << "the held fragment's pair broke";
  EXPECT_EQ(problem.failure()->broken(), broken);
  EXPECT_EQ(problem.failure()->peak().ratio, 0.0) << "the peak is over the bonds that can break";
  EXPECT_EQ(problem.fragment_particles(), 2);
}

// A fragment comes back into contact as a fixed obstacle. Two blocks (30 x 20 particles each,
// dx = 1 mm) touch along y = 20 mm; the upper one is pressed down by 1.2 dx. Before loading,
// a particle of the lower block on the interface is cut loose (moved 10 dx, which stretches
// every bond it has past s_c = 0.68 of G_c = 1e6 J/m^2, then put back). Under the press the
// lower block's interface moves down about 0.6 dx, away from the held particle, while the
// upper block comes down onto it: the pair between the held particle and the upper
// particle above it must carry a force, the held particle must push that particle up, and
// no pair may cross. Before this change the held particle's pairs were inactive and the
// upper block passed over it without a force. Exact enforcement (the default): the held
// particle's corner pairs, whose cells face each other over 1% of a face, stalled the
// multiplier updates (closure 0.0033 after 30 updates) until their closure counted by the
// window (docs/theory/contact.md, section 8, "Updates around the solve").
TEST(Fragments, AHeldFragmentIsAnObstacleToTheRest) {
  const double dx = 1e-3, W = 30 * dx, H = 20 * dx, press = 1.2 * dx, mid = 0.5 * W;
  std::ostringstream y;
  y.precision(17);
  y << "name: blocks\n"
    << "materials:\n  mat: {E: 1.0e9, nu: 0.3, thickness: 1.0e-3, kinematics: small}\n"
    << "discretization: {spacing: " << dx << ", horizon_factor: 3}\n"
    << "bodies:\n"
    << "  lower: {material: mat, rectangle: {min: [0, 0], max: [" << W << ", " << H << "]}}\n"
    << "  upper: {material: mat, rectangle: {min: [0, " << H << "], max: [" << W << ", " << 2 * H << "]}}\n"
    << "boundary:\n"
    << "  - {body: lower, edge: bottom, uy: 0}\n"
    << "  - {body: lower, region: {min: [" << mid - dx << ", 0], max: [" << mid + dx << ", " << dx
    << "]}, ux: 0}\n"
    << "  - {body: upper, edge: top, uy: " << -press << "}\n"
    << "  - {body: upper, region: {min: [" << mid - dx << ", " << 2 * H - dx << "], max: [" << mid + dx
    << ", " << 2 * H << "]}, ux: 0}\n"
    << "contact:\n  enabled: true\n  friction: 0\n  interfaces:\n    - {bodies: "
       "[lower, upper]}\n"
    << "failure: {criterion: stretch, G_c: 1.0e6}\n"
    << "loading: {steps: 2}\n"
    << "solver:\n  linear: umfpack\n  newton: {rtol: 1.0e-10}\n";
  const Scene scene = test::scene_from_yaml(y.str());
  const Model model = discretise(scene);
  QuasiStaticProblem problem(model, problem_options(scene));
  const Particles& p = model.particles;
  // The lower block's interface particle nearest mid-width (its centre is dx/2 below y = H).
  Index held = -1, above = -1;
  for (Index i = 0; i < p.size(); ++i) {
    if (p.fictitious[i]) continue;
    if ((p.position[i] - Vec2(mid + 0.5 * dx, H - 0.5 * dx)).norm() < 0.1 * dx) held = i;
    if ((p.position[i] - Vec2(mid + 0.5 * dx, H + 0.5 * dx)).norm() < 0.1 * dx) above = i;
  }
  ASSERT_GE(held, 0);
  ASSERT_GE(above, 0);
  const Index fx = model.constraints.free_index[2 * held];
  VectorXd x = VectorXd::Zero(problem.n_unknowns());
  x[fx] = 10 * dx;
  problem.set_load_factor(0.0);
  while (problem.advance_irreversible_state(x) > 0) problem.commit(x);
  ASSERT_EQ(problem.failure()->broken(), model.bonds.family_size(held)) << "exactly the moved particle's bonds break";
  x[fx] = 0.0;  // back where it was, with no bond
  problem.commit(x);
  ASSERT_EQ(problem.fragment_particles(), 1);

  std::unique_ptr<LinearSolver> linear;
  const std::unique_ptr<StepSolver> solver = make_step_solver(scene, problem, linear);
  LoadSteppingObserver quiet;
  const RunReport run = run_load_steps(problem, *solver, x, scene.loading, quiet);
  ASSERT_TRUE(run.completed) << run.message;
  EXPECT_EQ(problem.failure()->broken(), model.bonds.family_size(held)) << "the press breaks no other bond";
  VectorXd r;
  problem.evaluate(x, r, nullptr);
  EXPECT_LT(r.norm(), 1e-8 * problem.force_scale());
  EXPECT_EQ(x[fx], 0.0) << "the fragment is held";

  // The held particle and the one above it: the pair carries a normal force, which pushes the
  // upper particle up (+y), and the held fragments take the reaction.
  const ContactSystem& c = *problem.contact();
  EXPECT_GT(problem.fragment_contacts(), 0);
  Index pair = -1;
  for (auto* e = c.incident_begin(held); e != c.incident_end(held); ++e)
    if (e->other == above) pair = e->pair;
  ASSERT_GE(pair, 0) << "the interface pair exists";
  EXPECT_NE(c.result(pair).status, PairStatus::open);
  VectorXd f;
  c.contact_force(f);
  // 1e-6 of the press force's scale is far below the pair force (a fraction of the column
  // force E eps dx t ~ 30 N) and far above round-off.
  EXPECT_GT(f[2 * above + 1], 1e-6 * problem.force_scale()) << "the held particle pushes the upper block up";
  EXPECT_GT(problem.fragment_reaction(), 0.0);
  VectorXd u;
  problem.expand(x, u);
  EXPECT_LT(c.first_crossed(u), 0) << "no pair has crossed";

  // The contact zone that matrix-free GMRES solves exactly (assembly/contact_zone.hpp) holds
  // the held particle by its pair, and decouples its unknowns as the bond matrix does: a
  // positive diagonal and nothing else in their rows and columns (else its block would be
  // singular: the particle has no bond).
  SparseMatrix Pz;
  ASSERT_TRUE(problem.assemble_contact_zone(Pz));
  const Index fy = model.constraints.free_index[2 * held + 1];
  int diagonals = 0;
  for (Index col = 0; col < Pz.outerSize(); ++col)
    for (SparseMatrix::InnerIterator it(Pz, col); it; ++it) {
      const bool held_entry = it.row() == fx || it.row() == fy || col == fx || col == fy;
      if (!held_entry) continue;
      if (it.row() == col) {
        EXPECT_GT(it.value(), 0.0);
        ++diagonals;
      } else {
        EXPECT_EQ(it.value(), 0.0) << "(" << it.row() << ", " << col << ")";
      }
    }
  EXPECT_EQ(diagonals, 2) << "both unknowns of the held particle are rows of the zone";
}

}  // namespace
}  // namespace peristat
