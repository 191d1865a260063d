#include "solvers/linear/krylov_vectors.hpp"

#include <algorithm>
#include <cmath>

namespace peristat {

namespace {
/// Below this many chunks the threads' start costs more than the pass they would share.
constexpr Index kThreadedChunks = 4;

/// sum over [begin, end) of a_j b_j, in index order
double chunk_dot(const double* a, const double* b, Index begin, Index end) {
  double s = 0.0;
  for (Index j = begin; j < end; ++j) s += a[j] * b[j];
  return s;
}
}  // namespace

Index KrylovVectors::chunks(Index n) {
  const Index c = (n + kChunk - 1) / kChunk;
  if (static_cast<Index>(m_partial.size()) < c) m_partial.resize(c);
  return c;
}

double KrylovVectors::total(Index c) const {
  double s = 0.0;
  for (Index i = 0; i < c; ++i) s += m_partial[i];
  return s;
}

double KrylovVectors::dot(const double* a, const double* b, Index n) {
  const Index c = chunks(n);
  double* partial = m_partial.data();
#pragma omp parallel for schedule(static) if (c >= kThreadedChunks)
  for (Index i = 0; i < c; ++i) partial[i] = chunk_dot(a, b, i * kChunk, std::min(n, (i + 1) * kChunk));
  return total(c);
}

double KrylovVectors::orthogonalize(const double* basis, Index n, int k, double* q, double* h) {
  const Index c = chunks(n);
  double* partial = m_partial.data();
  double norm2 = 0.0;
  if (k > 0) h[0] = dot(basis, q, n);
#pragma omp parallel if (c >= kThreadedChunks)
  for (int i = 0; i < k; ++i) {
    const double* v = basis + static_cast<Index>(i) * n;
    const double* next = i + 1 < k ? v + n : q;  // the next column, or q itself for the norm
    const double hi = h[i];
#pragma omp for schedule(static)
    for (Index ch = 0; ch < c; ++ch) {
      const Index begin = ch * kChunk, end = std::min(n, (ch + 1) * kChunk);
      for (Index j = begin; j < end; ++j) q[j] -= hi * v[j];
      partial[ch] = chunk_dot(next, q, begin, end);
    }  // the implicit barrier: every chunk's partial sum is in
#pragma omp single
    {
      if (i + 1 < k)
        h[i + 1] = total(c);
      else
        norm2 = total(c);
    }  // and the single's: h[i + 1] is seen by every thread
  }
  if (k == 0) norm2 = dot(q, q, n);
  return std::sqrt(norm2);
}

}  // namespace peristat
