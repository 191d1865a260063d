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

/// The nodes (the particles that have an unknown, in particle order) in `ranks` ranges of
/// equal count; -1 for the particles without an unknown.
std::vector<int> strip_owners(const Constraints& constraints, int ranks);

/// Gives every particle without an owner (-1) the owner of the nearest owned particle, counted
/// in steps of the bond stencil (breadth-first from every owned particle at once, in particle
/// order); one that no step reaches goes to rank 0. A mirror ghost then takes its source's
/// owner. Owners unlike LatticePartition's regions, for the parts' tests.
void complete_owners(const Model& model, std::vector<int>& owner);

}  // namespace peristat::test
