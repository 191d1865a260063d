// A load-stepping observer that keeps the report of every converged step (the tests that
// read a run's steps after it).
#pragma once

#include <vector>

#include "solvers/load_stepping.hpp"

namespace peristat::test {

class StepLog final : public LoadSteppingObserver {
 public:
  void step_done(const StepReport& step, const VectorXd& /*x*/) override { steps.push_back(step); }
  std::vector<StepReport> steps;  ///< in the order they converged
};

}  // namespace peristat::test
