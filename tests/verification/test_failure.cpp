// Quasi-static bond breaking (issue 5, first part): no bond breaks below the threshold,
// the first bonds to break sit at the notch tip, and Newton and ADR break the same bonds.
#include <cmath>
#include <string>

#include <gtest/gtest.h>

#include "support/solve.hpp"

namespace peristat {
namespace {

// A 40 x 20 plate (dx = 1 mm, E = 1 GPa) with an edge notch from the left edge to x = 15 mm
// at mid-height, pulled apart by `pull` at the top edge (bottom uy = 0). Critical stretch
// from G_c = 10 J/m^2: s_c = 2.1e-3 (docs/theory/failure.md).
std::string notch(double pull, bool failure, const std::string& solver = "{linear: umfpack}") {
  std::string y = R"(name: notch
materials:
  m: {E: 1.0e9, nu: 0.3, thickness: 1.0e-3, kinematics: small}
discretization: {spacing: 1.0e-3, horizon_factor: 3}
bodies:
  plate: {material: m, rectangle: {min: [0, 0], max: [0.04, 0.02]}}
cracks:
  - {from: [-0.001, 0.01], to: [0.015, 0.01]}
boundary:
  - {body: plate, edge: bottom, uy: 0}
  - {body: plate, edge: top, uy: )" + std::to_string(pull) + R"(}
  - {body: plate, region: {min: [0.039, 0], max: [0.04, 0.001]}, ux: 0}
loading: {steps: 1}
solver: )" + solver + "\n";
  if (failure) y += "failure: {criterion: stretch, G_c: 10.0}\n";
  return y;
}

TEST(Failure, NoBondBreaksBelowTheThreshold) {
  // 2e-5 m: the largest bond stretch (at the notch tip) stays below s_c.
  auto with = test::solve_scene(notch(2e-5, true));
  auto without = test::solve_scene(notch(2e-5, false));
  ASSERT_TRUE(with->run.completed && without->run.completed);
  EXPECT_EQ(with->problem->broken_bonds(), 0);
  EXPECT_EQ(with->steps.at(0).resolves, 0);
  // Checking the criterion changes nothing else: the same answer to round-off.
  EXPECT_LT((with->u - without->u).norm(), 1e-12 * without->u.norm());
}

TEST(Failure, FirstBondsBreakAtTheNotchTip) {
  auto s = test::solve_scene(notch(2.5e-5, true));
  ASSERT_TRUE(s->run.completed) << s->run.message;
  VectorXd d;
  s->problem->damage(d);
  const Vec2 tip(0.015, 0.01);
  const double delta = 3e-3;
  int damaged = 0;
  double far = 0.0;
  for (Index i = 0; i < d.size(); ++i) {
    if (d[i] <= 0.0) continue;
    ++damaged;
    far = std::max(far, (s->model.particles.position[i] - tip).norm());
  }
  std::printf("notch, pull 2.5e-5 m: %ld bonds broken in %d re-solves; %d damaged particles, farthest %.2f delta "
              "from the tip\n",
              static_cast<long>(s->problem->broken_bonds()), s->steps.at(0).resolves, damaged, far / delta);
  EXPECT_GT(s->problem->broken_bonds(), 0);
  EXPECT_GE(s->steps.at(0).resolves, 1);
  // Every damaged particle is an end of a broken bond: within two horizons of the tip.
  EXPECT_LT(far, 2.0 * delta);
}

TEST(Failure, NewtonAndAdrBreakTheSameBonds) {
  auto newton = test::solve_scene(notch(2.5e-5, true, "{linear: umfpack, newton: {rtol: 1.0e-12}}"));
  auto adr = test::solve_scene(notch(2.5e-5, true, "{type: adr, adr: {rtol: 1.0e-10}}"));
  ASSERT_TRUE(newton->run.completed && adr->run.completed) << adr->run.message;
  VectorXd dn, da;
  newton->problem->damage(dn);
  adr->problem->damage(da);
  std::printf("Newton broke %ld bonds in %d re-solves, ADR %ld in %d (%ld ADR iterations); max damage difference "
              "%.3e\n",
              static_cast<long>(newton->problem->broken_bonds()), newton->steps.at(0).resolves,
              static_cast<long>(adr->problem->broken_bonds()), adr->steps.at(0).resolves, adr->iterations(),
              (dn - da).cwiseAbs().maxCoeff());
  EXPECT_EQ(newton->problem->broken_bonds(), adr->problem->broken_bonds());
  EXPECT_EQ((dn - da).cwiseAbs().maxCoeff(), 0.0);  // the same bonds, hence the same damage
}

}  // namespace
}  // namespace peristat
