// When a kept preconditioner (a factor, a MueLu hierarchy) is renewed: the rule of
// solvers/linear/preconditioner_reuse.hpp on scripted solves, whose iteration counts and
// achieved residuals are chosen to sit on either side of its thresholds.
#include <gtest/gtest.h>

#include "solvers/linear/preconditioner_reuse.hpp"

namespace peristat {
namespace {

/// Drives PreconditionerReuse as factor_krylov.cpp and belos_solver.cpp do, and counts builds.
struct Scripted {
  PreconditionerReuse reuse;
  Eigen::ComputationInfo info = Eigen::Success;
  int iterations = 0;
  double error = 0.0;
  int builds = 0;
  bool have = false;

  /// One solve that takes `its` iterations to reach `achieved` (relative residual), in the
  /// problem's discrete state `state`; a build happens first when one is due (as factorize()
  /// then drops the old one). `converges` false: the first run does not converge.
  void solve(std::uint64_t state, int its, double achieved, bool converges = true) {
    if (reuse.due()) have = false;
    reuse.set_state(state);
    bool first_run = true;
    reuse.solve(
        have,
        [&] {
          ++builds;
          have = true;
          info = Eigen::Success;
          reuse.built();
        },
        [&] {
          iterations = its;
          error = achieved;
          info = (first_run && !converges) ? Eigen::NoConvergence : Eigen::Success;
          first_run = false;
        },
        info, iterations, error);
  }
};

TEST(PreconditionerReuse, SlowerSolvesInAnUnchangedStateKeepIt) {
  // The tension plate at 1000 x 1000: 14 iterations for the predictor, then 62, 145, 104 for
  // Newton's corrections, the state never changing. The old rule renewed after the 62 (62 >
  // 2 * 14 + 5): a new hierarchy then saved no iteration and cost 23 s of set-up.
  Scripted s;
  s.solve(7, 14, 9.6e-4);
  s.solve(7, 62, 9.4e-4);
  s.solve(7, 145, 1.3e-6);
  s.solve(7, 104, 9.7e-4);
  EXPECT_EQ(s.builds, 1);
  EXPECT_FALSE(s.reuse.due());
}

TEST(PreconditionerReuse, SlowerSolvesAfterTheStateChangedRenewIt) {
  // Case 4.2: the predictor's preconditioner serves 12 iterations; Newton's first correction,
  // with the contact pairs now slipping, takes 37. 37 > 2 * 12 + 5 at the same decades:
  // renewed (without the renewal the run took 505 Krylov iterations instead of 397).
  Scripted s;
  s.solve(1, 12, 9.2e-4);
  s.solve(2, 37, 9.2e-4);
  EXPECT_TRUE(s.reuse.due());
  s.solve(2, 20, 9.2e-4);
  EXPECT_EQ(s.builds, 2);
  // In a changed state, just below the threshold (2 * 20 + 5): kept; just above: renewed.
  s.solve(3, 2 * 20 + 4, 9.2e-4);
  EXPECT_FALSE(s.reuse.due());
  s.solve(3, 2 * 20 + 6, 9.2e-4);
  EXPECT_TRUE(s.reuse.due());
}

TEST(PreconditionerReuse, TheThresholdScalesWithTheDecadesASolveAskedFor) {
  // 10 iterations for 3 decades (1e-3): about 3.3 per decade. A solve to 1e-9 (9 decades)
  // in 60 iterations is as fast per decade (6.7 < 2 * 3.3 + margin): kept, although 60 > 2 *
  // 10 + 5, the old count's threshold. 80 for the same 9 decades is not (80 > 2 * 30 + 5).
  Scripted s;
  s.solve(1, 10, 1e-3);
  s.solve(2, 60, 1e-9);
  EXPECT_FALSE(s.reuse.due());
  s.solve(2, 80, 1e-9);
  EXPECT_TRUE(s.reuse.due());
}

TEST(PreconditionerReuse, AFailedSolveWithAServedOneIsRetriedWithANewOne) {
  // Whatever the state: a preconditioner that has served before and lets a solve fail is
  // rebuilt at once, and the solve runs again.
  Scripted s;
  s.solve(5, 10, 1e-3);
  s.solve(5, 30, 1e-3, /*converges=*/false);
  EXPECT_EQ(s.builds, 2);
  EXPECT_EQ(s.info, Eigen::Success);
  // A new one that fails is not rebuilt again (nothing better to try).
  Scripted t;
  t.solve(5, 10, 1e-3, /*converges=*/false);
  EXPECT_EQ(t.builds, 1);
  EXPECT_EQ(t.info, Eigen::NoConvergence);
}

TEST(PreconditionerReuse, DecadesOfExactAndStalledSolves) {
  // An exact answer (residual 0) counts the most decades, a stalled one the fewest, so that
  // neither divides by zero.
  EXPECT_EQ(PreconditionerReuse::decades(0.0), PreconditionerReuse::kMaxDecades);
  EXPECT_EQ(PreconditionerReuse::decades(2.0), PreconditionerReuse::kMinDecades);
  EXPECT_NEAR(PreconditionerReuse::decades(1e-6), 6.0, 1e-12);
}

}  // namespace
}  // namespace peristat
