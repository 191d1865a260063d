// Load stepping with cut-backs on a problem whose behaviour is known exactly: a single
// unknown with r(x) = x - lambda that "fails" (non-finite residual) beyond a load factor.
#include <cmath>
#include <limits>

#include <gtest/gtest.h>

#include "solvers/linear/linear_solver.hpp"
#include "solvers/load_stepping.hpp"
#include "solvers/newton.hpp"

namespace peristat {
namespace {

class ScalarProblem final : public Problem {
 public:
  explicit ScalarProblem(double breaks_at) : m_breaks_at(breaks_at) {}
  Index n_unknowns() const override { return 1; }
  void set_load_factor(double l) override { m_lambda = l; }
  double load_factor() const override { return m_lambda; }
  void evaluate(const VectorXd& x, VectorXd& r, SparseMatrix* K) override {
    r.resize(1);
    r[0] = m_lambda > m_breaks_at ? std::numeric_limits<double>::quiet_NaN() : x[0] - m_lambda;
    if (K) K->coeffRef(0, 0) = 1.0;
  }
  double force_scale() const override { return 1.0; }
  SparseMatrix make_tangent() const override {
    SparseMatrix K(1, 1);
    K.insert(0, 0) = 0.0;
    K.makeCompressed();
    return K;
  }
  bool tangent_symmetric() const override { return true; }
  bool tangent_constant() const override { return false; }
  void commit(const VectorXd& x) override { committed.push_back(x[0]); }
  std::vector<double> committed;

 private:
  double m_breaks_at;
  double m_lambda = 0.0;
};

struct Outcome {
  RunReport report;
  std::vector<StepReport> steps;
};

Outcome run(ScalarProblem& p, int steps, int max_cutbacks) {
  LinearOptions lo;
  lo.type = "ldlt";
  auto linear = make_linear_solver(lo);
  NewtonOptions no;
  NewtonSolver newton(p, *linear, no);
  VectorXd x = VectorXd::Zero(1);
  Loading loading;
  loading.steps = steps;
  loading.max_cutbacks = max_cutbacks;
  Outcome r;
  LoadSteppingCallbacks cb;
  cb.on_step = [&](const StepReport& s, const VectorXd&) { r.steps.push_back(s); };
  r.report = run_load_steps(p, newton, x, loading, cb);
  return r;
}

TEST(LoadStepping, EqualStepsReachLoadFactorOne) {
  ScalarProblem p(10.0);
  const Outcome r = run(p, 4, 3);
  ASSERT_TRUE(r.report.completed);
  ASSERT_EQ(r.steps.size(), 4u);
  for (int k = 0; k < 4; ++k) EXPECT_DOUBLE_EQ(r.steps[k].load_factor, (k + 1) / 4.0);
  EXPECT_DOUBLE_EQ(p.committed.back(), 1.0);
}

// Breaks beyond 0.6 with steps of 0.5: step 2 halves to 0.75 (fails), 0.625 (fails), then
// stops after 2 cut-backs. Step 1 is kept; nothing beyond 0.6 is ever committed.
TEST(LoadStepping, CutBacksThenStopKeepingConvergedSteps) {
  ScalarProblem p(0.6);
  const Outcome r = run(p, 2, 2);
  EXPECT_FALSE(r.report.completed);
  EXPECT_EQ(r.report.steps_done, 1);
  ASSERT_EQ(r.steps.size(), 1u);
  EXPECT_NE(r.report.message.find("did not converge"), std::string::npos);
  for (double x : p.committed) EXPECT_LE(x, 0.6);
}

// Breaks beyond 0.9: step 2 (to 1.0) fails, the cut-back sub-step to 0.75 converges, the
// next attempt (0.75 -> 1.0) fails again... with enough cut-backs the step cannot reach 1.0,
// so the run stops; every committed state is an equilibrium below the break.
TEST(LoadStepping, SubStepsAreCommittedOnlyWhenConverged) {
  ScalarProblem p(0.9);
  const Outcome r = run(p, 2, 3);
  EXPECT_FALSE(r.report.completed);
  EXPECT_EQ(r.report.steps_done, 1);
  ASSERT_GE(p.committed.size(), 2u);
  for (double x : p.committed) EXPECT_LE(x, 0.9);
  EXPECT_GT(p.committed.back(), 0.75) << "sub-steps advanced past the last nominal step";
}

}  // namespace
}  // namespace peristat
