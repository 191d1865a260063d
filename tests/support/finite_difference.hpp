// One finite-difference harness for every derivative check in the tests: central
// differences of a function, column by column, against its analytic Jacobian.
#pragma once

#include <functional>
#include <ostream>
#include <vector>

#include <Eigen/Dense>

#include "assembly/problem.hpp"

namespace peristat::test {

/// The function whose Jacobian is checked: writes f(x) into `f` (the callee sizes it).
using VectorFunction = std::function<void(const VectorXd& x, VectorXd& f)>;

/// One entry of the Jacobian: analytic J(row, col), its central difference, and
/// |difference - analytic| / scale.
struct JacobianEntry {
  Index row = 0, col = 0;
  double analytic = 0.0, difference = 0.0, error = 0.0;
};

struct FiniteDifferenceCheck {
  /// max over all entries of |central difference - J| / scale: the number to compare with
  /// the test's tolerance.
  double worst = 0.0;
  /// max |J| (max |central difference| where J is zero throughout, so that a Jacobian
  /// wrongly zero cannot pass).
  double scale = 0.0;
  Eigen::MatrixXd jacobian;            ///< the analytic Jacobian, dense
  std::vector<JacobianEntry> largest;  ///< the 10 worst entries, worst first
};

/// Central differences (f(x + h e_j) - f(x - h e_j)) / 2h of every column j against J
/// (rows of f by columns of x). f is evaluated at x +- h e_j only.
FiniteDifferenceCheck check_jacobian(const VectorFunction& f, const VectorXd& x, double h,
                                     const Eigen::MatrixXd& J);

/// The same for a problem: the tangent assembled by evaluate(x, r, &K) against central
/// differences of the residual (the problem's state is left at x - h e_n).
FiniteDifferenceCheck check_tangent(Problem& problem, const VectorXd& x, double h);

/// n entries uniform in [-scale, scale], reproducible from `seed` (states and directions of
/// the derivative checks).
VectorXd random_vector(Index n, double scale, unsigned seed);

/// Prints the scale and the worst entries, for failure messages: EXPECT_LT(c.worst, tol) << c.
std::ostream& operator<<(std::ostream& os, const FiniteDifferenceCheck& c);

}  // namespace peristat::test
