// The Ranks room (src/parallel): one process, and 2 to 4 ranks emulated by threads, pass the
// checks that MPI's ranks pass in tests/mpi/test_ranks.cpp (support/ranks_checks.hpp).
#include <cmath>
#include <stdexcept>
#include <string>

#include <gtest/gtest.h>

#include "parallel/thread_ranks.hpp"
#include "support/ranks_checks.hpp"

namespace peristat {
namespace {

TEST(Ranks, OneProcessIsOneRank) {
  const Ranks& one = serial_ranks();
  EXPECT_EQ(one.rank(), 0);
  EXPECT_EQ(one.size(), 1);
  test::check_reductions(one);
  test::check_gathers(one);
  test::check_exchanges(one);
  // A -0.0 stays itself: one process's sum is the value, bit for bit.
  EXPECT_TRUE(std::signbit(one.sum(-0.0)));
}

TEST(Ranks, ThreadsEmulateRanks) {
  for (const int P : {2, 3, 4}) {
    SCOPED_TRACE("ranks " + std::to_string(P));
    ThreadNet net(P);
    net.run([](const ThreadRanks& ranks) {
      test::check_reductions(ranks);
      test::check_gathers(ranks);
      test::check_exchanges(ranks);
    });
  }
}

TEST(Ranks, AnExceptionOnOneRankReachesTheCaller) {
  // The rank that throws leaves the collectives; the others finish theirs without it.
  ThreadNet net(3);
  EXPECT_THROW(net.run([](const ThreadRanks& ranks) {
                 if (ranks.rank() == 1) throw std::runtime_error("rank 1 fails");
                 (void)ranks.sum(1.0);
               }),
               std::runtime_error);
}

TEST(Ranks, AGatherOfRowsRefusesAMissingOrRepeatedRow) {
  // Rows 0 and 2 of 3: row 1 given by no rank.
  const std::vector<std::int64_t> ids = {0, 2};
  const std::vector<double> values = {1.0, 3.0};
  EXPECT_THROW(serial_ranks().gather_rows_on_root(std::span<const std::int64_t>(ids),
                                                  std::span<const double>(values), 1, 3),
               std::logic_error);
  const std::vector<std::int64_t> twice = {1, 1};
  EXPECT_THROW(serial_ranks().gather_rows_on_root(std::span<const std::int64_t>(twice),
                                                  std::span<const double>(values), 1, 2),
               std::logic_error);
}

}  // namespace
}  // namespace peristat
