// Owners of the particles for the unit tests of the ranks' code (run on ThreadRanks,
// src/parallel/thread_ranks.hpp): cuts that RCB would make, without starting MPI.
#pragma once

#include <vector>

#include "discretisation/model.hpp"

namespace peristat::test {

/// Owners by x: the particles that have an unknown, ordered by x (then by index), in `ranks`
/// ranges of equal count (where RCB's first cut falls on the test plates; strip_owners()
/// gives the strips by particle index).
std::vector<int> x_cut_owners(const Model& model, int ranks);

}  // namespace peristat::test
