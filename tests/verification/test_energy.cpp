// The energy ledger and the energy-balance invariant of every accepted state (issue 15,
// docs/theory/newton.md "Invariants of every accepted state"): on a linear problem the
// ledger's external work equals the work of the final reaction, 1/2 R u; the ledger balances;
// the trapezoid is exact with linearised kinematics and not with finite ones; contact pairs
// and broken bonds take work.
#include <cmath>

#include <gtest/gtest.h>

#include "support/scenes.hpp"
#include "support/solve.hpp"

namespace peristat {
namespace {

/// external + residual - (strain + contact + released + quadrature), relative to the external work.
double imbalance(const EnergyLedger& e) {
  return (e.external_work + e.residual_work - e.strain_energy - e.contact_work - e.released - e.quadrature) /
         e.external_work;
}

std::unique_ptr<test::Solved> tension(const std::string& kinematics, double strain, int steps) {
  test::PlateSpec spec;
  spec.nx = 24;
  spec.ny = 12;
  spec.kinematics = kinematics;
  spec.steps = steps;
  spec.boundary = test::tension_boundary(strain, spec);
  spec.solver = "  newton: {rtol: 1.0e-12}\n";
  return test::solve_scene(test::plate_yaml(spec));
}

// Linearised kinematics: the response is linear in the load, so the work of the prescribed
// displacement over the load path is 1/2 R u with the final reaction R, whatever the number
// of steps; the trapezoid is exact (quadrature at round-off).
TEST(Energy, LinearTensionWorkIsHalfTheFinalReactionTimesTheDisplacement) {
  const double strain = 1e-3;
  auto s = tension("small", strain, 4);
  ASSERT_TRUE(s->run.completed) << s->run.message;
  const EnergyLedger& e = s->problem->energy_ledger();
  const double u_right = strain * 24 * 1e-3;
  // Condition 1 is the right edge; its reaction pulls in +x on the body's side.
  const double half_Ru = 0.5 * std::abs(s->problem->reaction(1).x()) * u_right;
  std::printf("W_ext %.12e J, R u / 2 %.12e J, Pi %.12e J, Q %.3e J, worst %.3e\n", e.external_work, half_Ru,
              e.strain_energy, e.quadrature, e.worst_relative);
  // 1e-9: the residual's forces (rtol 1e-12) and round-off; the statement is exact.
  EXPECT_NEAR(e.external_work / half_Ru, 1.0, 1e-9);
  EXPECT_NEAR(e.strain_energy / e.external_work, 1.0, 1e-9);
  EXPECT_LT(std::abs(e.quadrature / e.external_work), 1e-12) << "the trapezoid is exact for a quadratic energy";
  EXPECT_LT(std::abs(imbalance(e)), 1e-12);
  EXPECT_EQ(e.checked, 4);
  EXPECT_LT(e.worst_relative, 1e-12);
}

// Finite kinematics, 10% strain in two steps: the trapezoid's error on the bonds' work is
// visible (the energy is not quadratic) and shrinks like the square of the step; the check's
// Simpson rule still matches the stored energy to high order.
TEST(Energy, FiniteKinematicsTrapezoidErrorShrinksWithTheStep) {
  double q[2];
  int k = 0;
  for (int steps : {2, 4}) {
    auto s = tension("finite", 0.1, steps);
    ASSERT_TRUE(s->run.completed) << s->run.message;
    const EnergyLedger& e = s->problem->energy_ledger();
    q[k++] = std::abs(e.quadrature / e.external_work);
    std::printf("%d steps: Q / W %.3e, worst Simpson difference %.3e\n", steps, q[k - 1], e.worst_relative);
    EXPECT_LT(std::abs(imbalance(e)), 1e-12) << "the ledger balances by construction, up to round-off";
    // Measured 1.4e-7 (2 steps) and 1.8e-8 (4 steps); the check's tolerance is 1e-6.
    EXPECT_LT(e.worst_relative, 1e-6);
  }
  EXPECT_GT(q[0], 1e-8) << "finite kinematics: the trapezoid is not exact";
  // Halving the step divides a second-order error by about 4 (3 to 5 allowed).
  EXPECT_GT(q[0] / q[1], 3.0);
  EXPECT_LT(q[0] / q[1], 5.0);
}

// The Simpson check evaluates the bonds at the midpoint of the increment and then puts x's
// forces, force laws and energy back without evaluating x again: what the last evaluate() left
// (the reactions, the stresses, the energy, which the results and the next commit read) must be
// x's to the bit, as a fresh evaluation at x makes them.
TEST(Energy, SimpsonCheckLeavesTheStatesForcesAndEnergy) {
  auto s = tension("finite", 0.1, 2);
  ASSERT_TRUE(s->run.completed) << s->run.message;
  QuasiStaticProblem& p = *s->problem;
  // A state away from the accepted one (the run's end), so that the midpoint is neither.
  const VectorXd x = 0.5 * s->x;
  VectorXd r(x.size()), r_again(x.size());
  p.evaluate(x, r, nullptr);
  const VectorXd force = p.internal_force();
  const double energy = p.energy();
  const Index probe = p.model().particles.size() / 2;
  const Mat2 stress = p.stress(probe);
  const Vec2 reaction = p.reaction(1);
  // The check runs (its verdict on this non-equilibrium state does not matter here).
  (void)p.check_converged_state(x);
  EXPECT_EQ(p.energy_ledger().checked, 2) << "the two steps' checks; this one is pending, not counted";
  EXPECT_TRUE((p.internal_force().array() == force.array()).all()) << "x's forces back, bit for bit";
  EXPECT_EQ(p.energy(), energy);
  EXPECT_TRUE((p.stress(probe).array() == stress.array()).all()) << "x's force laws back";
  EXPECT_EQ(p.reaction(1).x(), reaction.x());
  // The midpoint's forces are not x's: the comparison above could fail.
  VectorXd midpoint_r(x.size());
  p.evaluate(0.5 * (x + s->x), midpoint_r, nullptr);
  EXPECT_GT((p.internal_force() - force).norm(), 1e-3 * force.norm());
  p.evaluate(x, r_again, nullptr);
  EXPECT_TRUE((r_again.array() == r.array()).all()) << "evaluation is deterministic";
}

// Case 4.1 (frictional sliding plates) at twice the spacing: the contact pairs take work
// (stored in them plus dissipated by friction), and the ledger balances.
TEST(Energy, SlidingPlatesContactTakesWork) {
  auto s = test::solve_case("paper_4_1_sliding_plates", {"discretization.spacing=8e-4"});
  ASSERT_TRUE(s->run.completed) << s->run.message;
  const EnergyLedger& e = s->problem->energy_ledger();
  std::printf("W_ext %.6e J, Pi %.6e J, W_contact %.6e J, Q %.3e J\n", e.external_work, e.strain_energy,
              e.contact_work, e.quadrature);
  EXPECT_GT(e.contact_work, 0.01 * e.external_work) << "sliding under friction dissipates";
  EXPECT_LT(std::abs(imbalance(e)), 1e-12);
  EXPECT_LT(e.worst_relative, 1e-12) << "linearised kinematics: trapezoid exact";
}

}  // namespace
}  // namespace peristat
