// The vector work of a Krylov iteration (dot products, updates, Gram-Schmidt) on this
// program's OpenMP threads, with the same bits on any number of threads: a vector is cut into
// fixed chunks of kChunk entries, each chunk's partial sum is taken by one thread in index
// order, and the partial sums are added in chunk order by one thread. The answer depends on
// the length of the vectors only, not on the threads or their schedule.
#pragma once

#include <vector>

#include "core/types.hpp"

namespace peristat {

class KrylovVectors {
 public:
  /// Entries per chunk: 4096 doubles, 32 KB of each vector a pass reads, and 40 chunks for the
  /// threads to share in a vector of 160,000 unknowns (case 4.4 at dx = 0.01 m).
  static constexpr Index kChunk = 4096;

  /// a . b
  double dot(const double* a, const double* b, Index n);
  /// Modified Gram-Schmidt of q against the columns v_0 .. v_{k-1} of `basis` (column-major,
  /// leading dimension n): for each i in turn h_i = v_i . q, then q -= h_i v_i. Returns
  /// ||q|| after the last update; h receives h_0 .. h_{k-1}. One pass over q per column: the
  /// update by v_i and the product with v_{i+1} share it, chunk by chunk, which is the same
  /// arithmetic as the two passes of the textbook loop.
  double orthogonalize(const double* basis, Index n, int k, double* q, double* h);

 private:
  /// Partial sums, one per chunk: sized once per vector length, no allocation per call.
  std::vector<double> m_partial;
  Index chunks(Index n);
  /// The sum of m_partial[0 .. chunks) in order.
  double total(Index chunks) const;
};

}  // namespace peristat
