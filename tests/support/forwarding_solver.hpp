// A StepSolver that passes every call to another one: the base of test decorators that
// change or record one call (support/solve.cpp, unit/test_load_stepping.cpp).
#pragma once

#include "solvers/step_solver.hpp"

namespace peristat::test {

class ForwardingStepSolver : public StepSolver {
 public:
  explicit ForwardingStepSolver(StepSolver& inner) : m_inner(inner) {}
  SolveReport solve(VectorXd& x, IterationObserver* observer) override { return m_inner.solve(x, observer); }
  void prepare(const VectorXd& x) override { m_inner.prepare(x); }
  bool prepared() const override { return m_inner.prepared(); }
  SolveReport predict(VectorXd& x, double from) override { return m_inner.predict(x, from); }
  void invalidate_factorization() override { m_inner.invalidate_factorization(); }
  bool cutback_helps() const override { return m_inner.cutback_helps(); }
  double residual_tolerance(double force_scale) const override {
    return m_inner.residual_tolerance(force_scale);
  }
  void set_reproducible(bool reproducible) override { m_inner.set_reproducible(reproducible); }
  void set_last_load(bool last) override { m_inner.set_last_load(last); }

 protected:
  StepSolver& m_inner;
};

}  // namespace peristat::test
