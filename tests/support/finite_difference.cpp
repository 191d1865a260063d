#include "support/finite_difference.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>

namespace peristat::test {

namespace {
constexpr std::size_t kReported = 10;
}

FiniteDifferenceCheck check_jacobian(const VectorFunction& f, const VectorXd& x, double h,
                                     const Eigen::MatrixXd& J) {
  FiniteDifferenceCheck c;
  c.jacobian = J;
  Eigen::MatrixXd fd(J.rows(), J.cols());
  VectorXd fp, fm;
  for (Index j = 0; j < J.cols(); ++j) {
    VectorXd xp = x, xm = x;
    xp[j] += h;
    xm[j] -= h;
    f(xp, fp);
    f(xm, fm);
    fd.col(j) = (fp - fm) / (2 * h);
  }
  c.scale = J.size() > 0 ? J.cwiseAbs().maxCoeff() : 0.0;
  if (c.scale == 0.0 && fd.size() > 0) c.scale = fd.cwiseAbs().maxCoeff();
  if (c.scale == 0.0) return c;  // both identically zero: they agree
  const auto worse = [](const JacobianEntry& a, const JacobianEntry& b) { return a.error > b.error; };
  for (Index j = 0; j < J.cols(); ++j) {
    for (Index i = 0; i < J.rows(); ++i) {
      JacobianEntry e{i, j, J(i, j), fd(i, j), std::abs(fd(i, j) - J(i, j)) / c.scale};
      // A NaN anywhere fails every tolerance.
      if (std::isnan(e.error)) e.error = std::numeric_limits<double>::infinity();
      c.worst = std::max(c.worst, e.error);
      if (c.largest.size() < kReported || e.error > c.largest.back().error) {
        c.largest.insert(std::upper_bound(c.largest.begin(), c.largest.end(), e, worse), e);
        if (c.largest.size() > kReported) c.largest.pop_back();
      }
    }
  }
  return c;
}

FiniteDifferenceCheck check_tangent(Problem& problem, const VectorXd& x, double h) {
  SparseMatrix K = problem.make_tangent();
  VectorXd r;
  problem.evaluate(x, r, &K);
  const Eigen::MatrixXd Kd(K);  // tiny test models: a dense copy is fine
  return check_jacobian([&](const VectorXd& y, VectorXd& ry) { problem.evaluate(y, ry, nullptr); }, x, h, Kd);
}

std::ostream& operator<<(std::ostream& os, const FiniteDifferenceCheck& c) {
  os << "\nmax |J| = " << c.scale << "; worst entries (|difference - J| / max |J|):";
  for (const JacobianEntry& e : c.largest)
    os << "\n  J(" << e.row << "," << e.col << ") = " << e.analytic << ", central difference " << e.difference
       << ", error " << e.error;
  return os;
}

VectorXd random_vector(Index n, double scale, unsigned seed) {
  std::mt19937 gen(seed);
  std::uniform_real_distribution<double> d(-1.0, 1.0);
  VectorXd v(n);
  for (Index i = 0; i < n; ++i) v[i] = scale * d(gen);
  return v;
}

}  // namespace peristat::test
