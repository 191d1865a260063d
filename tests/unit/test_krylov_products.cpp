// The operator products a matrix-free Krylov solve makes (solvers/linear/factor_krylov.cpp).
// Each product is a tangent action, the largest single cost of a matrix-free Newton step
// (5.6 ms of 13 per GMRES iteration on case 4.4 at dx = 0.01 m, docs/performance.md). Newton's
// first guess is zero, whose product is zero: the initial residual is then b without one.
// GMRES makes one product per iteration and one per restart cycle (the true residual that
// decides); CG one per iteration.
#include <vector>

#include <gtest/gtest.h>

#include "solvers/linear/factor_krylov.hpp"
#include "solvers/linear/linear_solver.hpp"
#include "support/laplacian.hpp"

namespace peristat {
namespace {

constexpr Index kN = 100;

/// A tridiagonal operator 2 on the diagonal, -1 -skew below and -1 + skew above (skew = 0:
/// the SPD 1D Laplacian with springs to the ground at both ends), applied matrix-free and
/// counted; its preconditioner matrix is the Laplacian.
class CountingSystem final : public LinearSystem {
 public:
  explicit CountingSystem(double skew) : m_skew(skew) {}
  void apply(const VectorXd& v, VectorXd& y) override {
    ++applies;
    y.resize(kN);
    for (Index i = 0; i < kN; ++i) {
      double s = 2.0 * v[i];
      if (i > 0) s += (-1.0 - m_skew) * v[i - 1];
      if (i + 1 < kN) s += (-1.0 + m_skew) * v[i + 1];
      y[i] = s;
    }
  }
  std::vector<Index> reads() const override { return {}; }
  void preconditioner(SparseMatrix& P) override { P = test::laplacian_1d(kN); }
  long applies = 0;

 private:
  double m_skew;
};

struct Solved {
  long applies = 0;
  int iterations = 0;
  double residual = 0.0;  ///< ||b - A x|| / ||b||, recomputed here
};

/// One solve of A x = b from the guess x0 by the matrix-free Krylov solver with a CHOLMOD
/// factor of the Laplacian (GMRES when skew != 0, CG otherwise), to 1e-10.
Solved solve(double skew, const VectorXd& x0) {
  auto system = std::make_shared<CountingSystem>(skew);
  LinearOptions direct;
  direct.type = LinearSolverKind::cholmod;
  LinearOptions krylov;
  krylov.rtol = 1e-10;
  auto solver = make_factor_preconditioned_krylov(factor_preconditioner(make_linear_solver(direct)),
                                                  FactorSource::preconditioner_matrix, krylov, system, true);
  const SparseMatrix none;
  solver->configure({skew == 0.0, 1e-10, 0});
  solver->analyzePattern(none);
  solver->factorize(none);
  VectorXd b(kN);
  for (Index i = 0; i < kN; ++i) b[i] = 1.0 + 0.01 * static_cast<double>(i % 7);
  VectorXd x = x0;
  system->applies = 0;
  solver->solve(b, x);
  EXPECT_EQ(solver->info(), Eigen::Success);
  Solved s{system->applies, solver->stats().iterations, 0.0};
  VectorXd Ax;
  system->apply(x, Ax);
  s.residual = (b - Ax).norm() / b.norm();
  return s;
}

// Unsymmetric: GMRES. From zero, one product per iteration only (a cycle that converges ends
// on its estimate, no closing product; the restarts' products:
// ZoneCorrection.GmresAppliesTheOperatorOncePerIterationAndRestart); from another guess, one
// more for the initial residual. The true residual is within the tolerance all the same.
TEST(KrylovProducts, GmresFromZeroMakesNoProductForTheInitialResidual) {
  const Solved zero = solve(0.2, VectorXd::Zero(kN));
  ASSERT_GT(zero.iterations, 1);
  ASSERT_LT(zero.iterations, 60) << "one restart cycle (60 basis vectors) is what the count assumes";
  EXPECT_EQ(zero.applies, zero.iterations);
  EXPECT_LT(zero.residual, 1e-9);  // the solver's 1e-10, with room for the recomputed product

  const Solved guess = solve(0.2, VectorXd::Constant(kN, 0.5));
  ASSERT_LT(guess.iterations, 60);
  EXPECT_EQ(guess.applies, guess.iterations + 1);
  EXPECT_LT(guess.residual, 1e-9);
}

// Symmetric: CG, one product per iteration from zero, one more from another guess.
TEST(KrylovProducts, CgFromZeroMakesNoProductForTheInitialResidual) {
  const Solved zero = solve(0.0, VectorXd::Zero(kN));
  ASSERT_GT(zero.iterations, 0);
  EXPECT_EQ(zero.applies, zero.iterations);
  EXPECT_LT(zero.residual, 1e-9);

  const Solved guess = solve(0.0, VectorXd::Constant(kN, 0.5));
  EXPECT_EQ(guess.applies, guess.iterations + 1);
  EXPECT_LT(guess.residual, 1e-9);
}

}  // namespace
}  // namespace peristat
