// Zoltan2's recursive coordinate bisection (solver.belos.partition: rcb), in one process. In
// the verification tier: Zoltan initialises MPI, whose libraries the sanitizer build of the
// unit tier would report for their own leaks.
#include <algorithm>
#include <vector>

#include <gtest/gtest.h>

#include "solvers/trilinos/partition.hpp"

namespace peristat {
namespace {

// solver.belos.partition: rcb (Zoltan2): a 40 x 10 grid of points in 2 and 4 parts of equal
// count, the first cut across the longer side (x), and the same parts on a second call (every
// rank computes the owners by itself, so they must agree).
TEST(Partition, RcbCutsTheLongerSideIntoEqualCounts) {
  std::vector<double> x, y;
  for (int j = 0; j < 10; ++j)
    for (int i = 0; i < 40; ++i) {
      x.push_back(i + 0.5);
      y.push_back(j + 0.5);
    }
  const std::vector<int> two = rcb_parts(x, y, 2);
  ASSERT_EQ(two.size(), x.size());
  EXPECT_EQ(std::count(two.begin(), two.end(), 0), 200);
  EXPECT_EQ(std::count(two.begin(), two.end(), 1), 200);
  double x0 = -1.0, x1 = 1e9;  // the largest x of part 0 and the smallest of part 1, or the other way
  for (std::size_t k = 0; k < x.size(); ++k) {
    if (two[k] == two[0])
      x0 = std::max(x0, x[k]);
    else
      x1 = std::min(x1, x[k]);
  }
  EXPECT_LT(x0, x1) << "the cut runs across x, the longer side";
  const std::vector<int> four = rcb_parts(x, y, 4);
  for (int p = 0; p < 4; ++p) EXPECT_EQ(std::count(four.begin(), four.end(), p), 100) << "part " << p;
  EXPECT_EQ(rcb_parts(x, y, 4), four) << "deterministic";
}

}  // namespace
}  // namespace peristat
