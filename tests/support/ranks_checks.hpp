// Checks of a `Ranks` that every implementation must pass (tests/unit/test_ranks.cpp runs them
// on one process and on ranks emulated by threads, tests/mpi/test_ranks.cpp on MPI's ranks):
// the same body on each, so the implementations share one meaning. gtest assertions; every
// rank calls them at the same point (they are collective).
#pragma once

#include "parallel/ranks.hpp"

namespace peristat::test {

/// Sums in rank order (bit for bit, where the order changes the result), max, any,
/// sum_over_lower_ranks.
void check_reductions(const Ranks& ranks);
/// all_gather, gather_to_root, broadcast, gather_rows_on_root of 64-bit ids past 2^53 and of
/// doubles, with every rank giving a different count (rank 0 none).
void check_gathers(const Ranks& ranks);
/// all_to_all_v, and the three exchanges by owner (Part, Ghost, Owned) on a line of entries
/// cut into ranges: every ghost gets its owner's value, nothing else changes.
void check_exchanges(const Ranks& ranks);

}  // namespace peristat::test
