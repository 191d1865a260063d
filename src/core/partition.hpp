// How a distributed run splits its rows among MPI ranks: the one rule that the assembly
// (which rows a rank writes) and the Tpetra adapter (which rows a rank owns) share, so that
// the two can never disagree. Nothing about MPI here.
#pragma once

#include <cstdint>
#include <vector>

namespace peristat {

/// The nodes (the particles that have an unknown, in particle order) split into `ranks`
/// contiguous strips of equal count: rank r owns nodes [strip_start(r), strip_start(r + 1)).
inline std::int64_t strip_start(std::int64_t nodes, int rank, int ranks) {
  return nodes * rank / ranks;
}

}  // namespace peristat
