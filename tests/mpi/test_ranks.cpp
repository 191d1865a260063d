// MPI's ranks (src/parallel/mpi) pass the checks that one process and the emulated ranks pass
// in tests/unit/test_ranks.cpp (support/ranks_checks.hpp). Run by ctest as `mpirun -n 2`.
#include <gtest/gtest.h>

#include "parallel/mpi/mpi_ranks.hpp"
#include "support/ranks_checks.hpp"

namespace peristat {
namespace {

TEST(MpiRanks, PassTheChecksOfEveryRanks) {
  const std::unique_ptr<Ranks> ranks = parallel::process_ranks();
  ASSERT_EQ(ranks->size(), 2) << "run under mpirun -n 2";
  test::check_reductions(*ranks);
  test::check_gathers(*ranks);
  test::check_exchanges(*ranks);
}

}  // namespace
}  // namespace peristat

int main(int argc, char** argv) {
  const peristat::parallel::Session mpi;
  ::testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
