// Every linear solver reaches the same equilibrium (docs/theory/newton.md, "Factor-preconditioned Krylov":
// the reused-factor Krylov path and a fresh factorisation every iteration "must reach the same answer").
#include <gtest/gtest.h>

#include "support/scenes.hpp"
#include "support/solve.hpp"

namespace peristat {
namespace {

VectorXd solve_with(const std::string& kinematics, const std::string& solver_yaml,
                    int* factorizations = nullptr) {
  test::PlateSpec spec;
  spec.nx = 30;
  spec.ny = 16;
  spec.kinematics = kinematics;
  spec.steps = 2;
  spec.boundary =
      "  - {body: plate, edge: left, ux: 0, uy: 0}\n  - {body: plate, edge: right, ux: 3.0e-4, uy: 5.0e-4}\n";
  spec.cracks = "  - {from: [0.01, 0.005], to: [0.016, 0.011]}\n";
  spec.solver = solver_yaml + "  newton: {rtol: 1.0e-11}\n";
  auto s = test::solve_scene(test::plate_yaml(spec));
  EXPECT_TRUE(s->run.completed) << solver_yaml << s->run.message;
  if (factorizations) {
    *factorizations = 0;
    for (const auto& st : s->steps) *factorizations += st.factorizations;
  }
  return s->u;
}

// Relative difference 1e-8: each solve stops at a relative residual of 1e-11 and the
// stiffness condition number of this plate is ~1e3.
void expect_same(const VectorXd& a, const VectorXd& b, const std::string& what) {
  EXPECT_LT((a - b).norm() / b.norm(), 1e-8) << what;
}

class LinearSolvers : public ::testing::TestWithParam<std::string> {};

TEST_P(LinearSolvers, AgreeWithCholmod) {
  const std::string kin = GetParam();
  const VectorXd ref = solve_with(kin, "  linear: cholmod\n");
  expect_same(solve_with(kin, "  linear: ldlt\n"), ref, "ldlt");
  expect_same(solve_with(kin, "  linear: umfpack\n"), ref, "umfpack");
  expect_same(solve_with(kin, "  linear: klu\n"), ref, "klu");
  const std::string krylov = "  krylov: {rtol: 1.0e-12, preconditioner: ";
  expect_same(solve_with(kin, "  linear: cg\n" + krylov + "bond}\n"), ref, "cg+bond");
  expect_same(solve_with(kin, "  linear: cg\n" + krylov + "cholmod}\n"), ref, "cg+cholmod");
  expect_same(solve_with(kin, "  linear: cg\n" + krylov + "ic}\n"), ref, "cg+ic");
  expect_same(solve_with(kin, "  linear: bicgstab\n" + krylov + "ilut}\n"), ref, "bicgstab+ilut");
}

INSTANTIATE_TEST_SUITE_P(Kinematics, LinearSolvers, ::testing::Values("finite", "small"));

// solver.linear: belos in one process (an MPI singleton): every preconditioner, each Krylov
// method and both tangents (assembled, and matrix-free with the preconditioner built from the
// bond matrix) reach cholmod's equilibrium. The same 1e-8 as above.
TEST(LinearSolvers, BelosAgreesWithCholmod) {
  const VectorXd ref = solve_with("finite", "  linear: cholmod\n");
  for (const std::string tangent : {"assembled", "matrix_free"})
    for (const std::string pc : {"bond_factor", "muelu", "ifpack2_ilut", "ifpack2_relaxation"})
      for (const std::string method : {"auto", "cg", "gmres"}) {
        const std::string yaml = "  linear: belos\n  belos: {rtol: 1.0e-12, method: " + method +
                                 ", preconditioner: " + pc + ", tangent: " + tangent + "}\n";
        expect_same(solve_with("finite", yaml), ref, "belos " + method + "+" + pc + "+" + tangent);
      }
}

// The reused factor is the point of cg+cholmod: fewer factorisations than Newton iterations.
TEST(LinearSolvers, FactorIsReusedAcrossIterations) {
  int direct = 0, reused = 0;
  solve_with("finite", "  linear: cholmod\n", &direct);
  solve_with("finite", "  linear: cg\n  krylov: {rtol: 1.0e-12, preconditioner: cholmod}\n", &reused);
  std::printf("factorisations: cholmod %d, cg+cholmod %d\n", direct, reused);
  EXPECT_LT(reused, direct);
}

}  // namespace
}  // namespace peristat
