// How a distributed run splits its rows among MPI ranks: the one rule that the assembly
// (which rows a rank writes) and the Tpetra adapter (which rows a rank owns) share, so that
// the two can never disagree. Nothing about MPI here.
#pragma once

#include <cstdint>
#include <functional>
#include <vector>

namespace peristat {

/// The nodes (the particles that have an unknown, in particle order) split into `ranks`
/// contiguous strips of equal count: rank r owns nodes [strip_start(r), strip_start(r + 1)).
inline std::int64_t strip_start(std::int64_t nodes, int rank, int ranks) {
  return nodes * rank / ranks;
}

/// Every rank's `mine` concatenated in rank order, the same on every rank (a collective
/// operation: every rank calls it at the same point; MPI_Allgatherv in a run under mpirun).
/// The decisions that read the whole model while each rank holds a part of it (bond failure
/// with partitioned bonds) gather each rank's share this way.
using GatherOverRanks = std::function<std::vector<double>(const std::vector<double>& mine)>;

}  // namespace peristat
