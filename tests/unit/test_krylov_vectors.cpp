// GMRES's Gram-Schmidt on the threads (solvers/linear/krylov_vectors.hpp): the same bits on
// any number of threads, and the arithmetic of modified Gram-Schmidt.
#include <cmath>
#include <random>
#include <vector>

#include <gtest/gtest.h>
#include <omp.h>

#include "solvers/linear/krylov_vectors.hpp"

namespace peristat {
namespace {

/// n x k columns of random entries in [-1, 1], column-major.
std::vector<double> random_columns(Index n, int k, unsigned seed) {
  std::mt19937 gen(seed);
  std::uniform_real_distribution<double> d(-1.0, 1.0);
  std::vector<double> v(static_cast<size_t>(n) * k);
  for (double& e : v) e = d(gen);
  return v;
}

/// Orthonormal columns by textbook modified Gram-Schmidt (serial), in place.
void orthonormalize(std::vector<double>& v, Index n, int k) {
  for (int j = 0; j < k; ++j) {
    double* q = v.data() + static_cast<Index>(j) * n;
    for (int i = 0; i < j; ++i) {
      const double* p = v.data() + static_cast<Index>(i) * n;
      double h = 0.0;
      for (Index r = 0; r < n; ++r) h += p[r] * q[r];
      for (Index r = 0; r < n; ++r) q[r] -= h * p[r];
    }
    double s = 0.0;
    for (Index r = 0; r < n; ++r) s += q[r] * q[r];
    for (Index r = 0; r < n; ++r) q[r] /= std::sqrt(s);
  }
}

// 1, 2 and 3 threads share the chunks differently; every chunk's sum is still one thread's, in
// index order, and the chunks are added in order: bit for bit the same q, h and norm. The
// vector (10 chunks and a partial one) and the 12 columns are large enough to be threaded.
TEST(KrylovVectors, GramSchmidtGivesTheSameBitsOnAnyNumberOfThreads) {
  const Index n = 10 * KrylovVectors::kChunk + 123;
  const int k = 12;
  std::vector<double> basis = random_columns(n, k, 3);
  orthonormalize(basis, n, k);
  const std::vector<double> q0 = random_columns(n, 1, 4);
  const int saved = omp_get_max_threads();
  std::vector<std::vector<double>> q, h;
  std::vector<double> norm;
  for (const int threads : {1, 2, 3}) {
    omp_set_num_threads(threads);
    KrylovVectors vectors;
    q.push_back(q0);
    h.emplace_back(k);
    norm.push_back(vectors.orthogonalize(basis.data(), n, k, q.back().data(), h.back().data()));
  }
  omp_set_num_threads(saved);
  for (int t = 1; t < 3; ++t) {
    EXPECT_EQ(q[t], q[0]) << t + 1 << " threads";
    EXPECT_EQ(h[t], h[0]) << t + 1 << " threads";
    EXPECT_EQ(norm[t], norm[0]) << t + 1 << " threads";
  }
}

// Against the textbook loop (h_i = v_i . q, then q -= h_i v_i, in turn): only the order of the
// dot products' additions differs, so q, h and ||q|| agree to a few rounding errors of the
// entries' size, 1e-13 (n = 41,083 terms of size 1 sum with errors near 1e-16 sqrt(n) ~ 2e-14).
// The result is orthogonal to every column to the same accuracy.
TEST(KrylovVectors, GramSchmidtIsModifiedGramSchmidtAndOrthogonalizes) {
  const Index n = 10 * KrylovVectors::kChunk + 123;
  const int k = 7;
  std::vector<double> basis = random_columns(n, k, 5);
  orthonormalize(basis, n, k);
  std::vector<double> q = random_columns(n, 1, 6), expected = q;
  std::vector<double> h(k), expected_h(k);
  for (int i = 0; i < k; ++i) {
    const double* v = basis.data() + static_cast<Index>(i) * n;
    double s = 0.0;
    for (Index r = 0; r < n; ++r) s += v[r] * expected[r];
    expected_h[i] = s;
    for (Index r = 0; r < n; ++r) expected[r] -= s * v[r];
  }
  double expected_norm2 = 0.0;
  for (const double e : expected) expected_norm2 += e * e;

  KrylovVectors vectors;
  const double norm = vectors.orthogonalize(basis.data(), n, k, q.data(), h.data());
  const double scale = std::sqrt(static_cast<double>(n));  // ||q0|| ~ sqrt(n / 3)
  for (int i = 0; i < k; ++i) EXPECT_NEAR(h[i], expected_h[i], 1e-13 * scale) << "h_" << i;
  for (Index r = 0; r < n; ++r) ASSERT_NEAR(q[r], expected[r], 1e-13) << "entry " << r;
  EXPECT_NEAR(norm, std::sqrt(expected_norm2), 1e-13 * scale);
  for (int i = 0; i < k; ++i)
    EXPECT_LT(std::abs(vectors.dot(basis.data() + static_cast<Index>(i) * n, q.data(), n)), 1e-12 * norm)
        << "column " << i;
}

// Small integers make every partial sum exact: the chunked sum is the exact dot product, on a
// length that is not a multiple of the chunk, and on one shorter than a chunk.
TEST(KrylovVectors, DotOfSmallIntegersIsExact) {
  for (const Index n : {Index{5}, 3 * KrylovVectors::kChunk + 17}) {
    std::vector<double> a(n), b(n);
    double exact = 0.0;
    for (Index r = 0; r < n; ++r) {
      a[r] = static_cast<double>(r % 7) - 3.0;
      b[r] = static_cast<double>(r % 5) - 2.0;
      exact += a[r] * b[r];  // integers below 2^53 throughout: exact in any order
    }
    KrylovVectors vectors;
    EXPECT_EQ(vectors.dot(a.data(), b.data(), n), exact) << "n = " << n;
  }
}

}  // namespace
}  // namespace peristat
