// The contact zone's exact correction (solvers/linear/zone_correction.hpp) and its place in
// the matrix-free GMRES (solvers/linear/factor_krylov.cpp): after the correction the zone's
// rows of the preconditioned residual vanish; GMRES asks for the zone's rows once per
// problem state and converges in fewer iterations with them; CG does without. And GMRES's
// count of the operator's applications.
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "solvers/linear/factor_krylov.hpp"
#include "solvers/linear/linear_solver.hpp"
#include "solvers/linear/zone_correction.hpp"
#include "support/laplacian.hpp"

namespace peristat {
namespace {

constexpr Index kM = 12;  // grid points per side: 144 unknowns

/// P's rows `in` selects, the others empty (what LinearSystem::contact_zone_rows gives).
SparseMatrix rows_of(const SparseMatrix& P, const std::function<bool(Index)>& in) {
  std::vector<Eigen::Triplet<double, Index>> t;
  for (Index c = 0; c < P.outerSize(); ++c)
    for (SparseMatrix::InnerIterator it(P, c); it; ++it)
      if (in(it.row())) t.emplace_back(it.row(), c, it.value());
  SparseMatrix Z(P.rows(), P.cols());
  Z.setFromTriplets(t.begin(), t.end());
  return Z;
}

bool column_band(Index k) {
  return k % kM >= 3 && k % kM <= 6;
}  // grid columns 3-6
bool row_band(Index k) {
  return k / kM >= 3 && k / kM <= 6;
}  // grid rows 3-6: as many

VectorXd wavy(Index n, double phase) {
  VectorXd v(n);
  for (Index i = 0; i < n; ++i) v[i] = std::sin(0.37 * static_cast<double>(i) + phase) + 0.1;
  return v;
}

/// After z += E P_zz^-1 E^T (v - P z), the zone's rows of v - P z are zero (to round-off:
/// 1e-12 of |v|, P's entries being O(1)), and z is untouched outside the zone.
void expect_exact_on(const SparseMatrix& P, ZoneCorrection& zone, const std::function<bool(Index)>& in) {
  const Index n = static_cast<Index>(P.rows());
  const VectorXd v = wavy(n, 0.0), z0 = wavy(n, 1.0);
  VectorXd z = z0;
  zone.apply(v, z);
  const VectorXd r = v - P * z;
  for (Index i = 0; i < n; ++i) {
    if (in(i))
      EXPECT_LT(std::abs(r[i]), 1e-12 * v.norm()) << "zone row " << i;
    else
      EXPECT_EQ(z[i], z0[i]) << "row " << i << " is outside the zone";
  }
}

TEST(ZoneCorrection, TheZonesRowsOfTheResidualVanish) {
  const SparseMatrix P = test::laplacian_2d(kM);
  ZoneCorrection zone;
  ASSERT_TRUE(zone.set(rows_of(P, column_band)));
  EXPECT_EQ(zone.size(), 4 * kM);
  expect_exact_on(P, zone, column_band);
}

// A zone of the same size with another pattern (a row band: vertical neighbours kM apart in
// its numbering instead of 4) must be analysed again: the old analysis would factor the new
// matrix wrongly.
TEST(ZoneCorrection, AnotherPatternOfTheSameSizeIsAnalysedAgain) {
  const SparseMatrix P = test::laplacian_2d(kM);
  ZoneCorrection zone;
  ASSERT_TRUE(zone.set(rows_of(P, column_band)));
  ASSERT_TRUE(zone.set(rows_of(P, row_band)));
  EXPECT_EQ(zone.size(), 4 * kM);
  expect_exact_on(P, zone, row_band);
  // And new values on the first pattern (2 P: the factor must be of the new values).
  const SparseMatrix P2 = 2.0 * P;
  ASSERT_TRUE(zone.set(rows_of(P2, column_band)));
  expect_exact_on(P2, zone, column_band);
}

// The same zone at another contact state: Pz's pattern is the last one's, its values others
// (here P with a diagonal that varies row by row), copied in place into the zone's rows and
// block. The correction must be exact for the new values and the same bits as a correction
// built afresh from them.
TEST(ZoneCorrection, NewValuesOnTheSamePatternAreCopiedInPlace) {
  const SparseMatrix P = test::laplacian_2d(kM);
  SparseMatrix Q = P;
  for (Index i = 0; i < Q.rows(); ++i) Q.coeffRef(i, i) += 0.1 * static_cast<double>(i % 7);
  ZoneCorrection kept, fresh;
  ASSERT_TRUE(kept.set(rows_of(P, column_band)));
  ASSERT_TRUE(kept.set(rows_of(Q, column_band)));
  ASSERT_TRUE(fresh.set(rows_of(Q, column_band)));
  expect_exact_on(Q, kept, column_band);
  const VectorXd v = wavy(kM * kM, 0.0);
  VectorXd z_kept = wavy(kM * kM, 1.0), z_fresh = z_kept;
  kept.apply(v, z_kept);
  fresh.apply(v, z_fresh);
  EXPECT_EQ(z_kept, z_fresh);
}

TEST(ZoneCorrection, NoRowsNoCorrection) {
  ZoneCorrection zone;
  EXPECT_FALSE(zone.set(SparseMatrix(kM * kM, kM * kM)));
  EXPECT_FALSE(zone.active());
  const VectorXd z0 = wavy(kM * kM, 1.0);
  VectorXd z = z0;
  zone.apply(wavy(kM * kM, 0.0), z);
  EXPECT_EQ(z, z0);
}

// A zero pivot (an unknown of the zone coupled to nothing, its row and column stored zeros:
// a particle without bonds that nothing holds) is refused, not applied.
TEST(ZoneCorrection, ASingularBlockIsRefused) {
  const SparseMatrix P = test::laplacian_2d(kM);
  SparseMatrix Z = rows_of(P, column_band);
  const Index k = 5 + kM * 5;
  ASSERT_TRUE(column_band(k));
  for (Index c = 0; c < Z.outerSize(); ++c)
    for (SparseMatrix::InnerIterator it(Z, c); it; ++it)
      if (it.row() == k || c == k) it.valueRef() = 0.0;
  ZoneCorrection zone;
  EXPECT_FALSE(zone.set(Z));
  EXPECT_FALSE(zone.active());
}

/// Jacobi of P: an inexact preconditioner (exact() false), as the V-cycle is; it may call
/// itself unsymmetric (as the GMRES V-cycle is) to see the solver's choice.
class Jacobi final : public Preconditioner {
 public:
  explicit Jacobi(bool symmetric = true) : m_symmetric(symmetric) {}
  void analyzePattern(const SparseMatrix&) override {}
  void factorize(const SparseMatrix& P) override {
    m_inverse = P.diagonal().cwiseInverse();
    ++m_builds;
  }
  void solve(VectorIn b, VectorXd& x) override {
    inputs.push_back(b.data());
    x = m_inverse.cwiseProduct(b);
  }
  Eigen::ComputationInfo info() const override { return Eigen::Success; }
  std::string name() const override { return "jacobi"; }
  long factorizations() const override { return m_builds; }
  bool symmetric() const override { return m_symmetric; }
  std::vector<const double*> inputs;  ///< where each solve() read b

 private:
  VectorXd m_inverse;
  long m_builds = 0;
  bool m_symmetric;
};

/// A = P + skew (S - S^T), S the grid's first super-diagonal (unsymmetric for skew != 0),
/// applied matrix-free (the products counted); its zone the column band, when `zone`. On an
/// m x m grid.
class ZoneSystem final : public LinearSystem {
 public:
  ZoneSystem(double skew, bool zone, Index m = kM) : m_P(test::laplacian_2d(m)), m_zone(zone) {
    m_A = m_P;
    for (Index k = 0; k + 1 < m * m; ++k) {
      m_A.coeffRef(k, k + 1) += skew;
      m_A.coeffRef(k + 1, k) -= skew;
    }
  }
  void apply(const VectorXd& v, VectorXd& y) override {
    ++products;
    y = m_A * v;
  }
  std::vector<Index> reads() const override { return {}; }
  void preconditioner(SparseMatrix& P) override { P = m_P; }
  bool contact_zone_rows(SparseMatrix& Pz) override {
    ++asked;
    if (!m_zone) return false;
    Pz = rows_of(m_P, column_band);
    return true;
  }
  const SparseMatrix& A() const { return m_A; }
  int asked = 0, products = 0;

 private:
  SparseMatrix m_P, m_A;
  bool m_zone;
};

struct Solves {
  std::vector<int> iterations;  ///< per solve
  std::vector<int> products;    ///< per solve: the operator's applications
  int asked = 0;                ///< calls of contact_zone_rows
};

/// Solves A x = b to 1e-10 once per entry of `states` (the problem's state at that solve),
/// with the matrix-free Krylov solver and the Jacobi preconditioner; every solve must
/// converge to a true residual below 1e-9.
Solves solve(double skew, bool zone, const std::vector<std::uint64_t>& states, Index m = kM,
             bool symmetric_preconditioner = true) {
  auto system = std::make_shared<ZoneSystem>(skew, zone, m);
  LinearOptions o;
  o.rtol = 1e-10;
  o.max_iterations = 2000;
  auto solver = make_factor_preconditioned_krylov(std::make_unique<Jacobi>(symmetric_preconditioner),
                                                  FactorSource::preconditioner_matrix, o, system, true);
  const SparseMatrix none;
  solver->analyzePattern(none);
  solver->factorize(none);
  const VectorXd b = wavy(m * m, 0.5);
  Solves run;
  for (const std::uint64_t state : states) {
    solver->configure({skew == 0.0, 1e-10, state});
    VectorXd x = VectorXd::Zero(m * m);
    const int before = system->products;
    solver->solve(b, x);
    run.products.push_back(system->products - before);
    EXPECT_EQ(solver->info(), Eigen::Success);
    EXPECT_LT((b - system->A() * x).norm() / b.norm(), 1e-9);
    run.iterations.push_back(solver->stats().iterations);
  }
  run.asked = system->asked;
  return run;
}

// GMRES (unsymmetric A): the zone's exact correction after Jacobi takes fewer iterations to
// the same tolerance; its rows are asked for once while the state is the same, again when it
// changes.
TEST(ZoneCorrection, GmresConvergesInFewerIterationsAndAsksOncePerState) {
  const Solves without = solve(0.3, false, {7, 7, 8});
  const Solves with = solve(0.3, true, {7, 7, 8});
  std::printf("GMRES iterations per solve: %d %d %d without the zone, %d %d %d with it\n",
              without.iterations[0], without.iterations[1], without.iterations[2], with.iterations[0],
              with.iterations[1], with.iterations[2]);
  for (std::size_t k = 0; k < 3; ++k) EXPECT_LT(with.iterations[k], without.iterations[k]) << "solve " << k;
  EXPECT_EQ(with.asked, 2) << "states 7, 7, 8: once for 7, once for 8";
}

// GMRES(60) from a zero guess applies the operator once per iteration, plus once at each
// restart (the next cycle starts from the true residual); a cycle that converges ends on its
// estimate, and solve() checks that the true residual is within the tolerance all the same
// (below 1e-9 for 1e-10). Without the zone on a 12 x 12 grid one cycle; on 24 x 24, restarts.
TEST(ZoneCorrection, GmresAppliesTheOperatorOncePerIterationAndRestart) {
  for (const Index m : {kM, 2 * kM}) {
    const Solves run = solve(0.3, false, {7}, m);
    const int iterations = run.iterations[0], cycles = (iterations + 59) / 60;
    std::printf("%d x %d grid: %d GMRES iterations in %d cycles, %d products\n", static_cast<int>(m),
                static_cast<int>(m), iterations, cycles, run.products[0]);
    EXPECT_EQ(run.products[0], iterations + cycles - 1) << m << " x " << m;
    if (m == kM) {
      EXPECT_EQ(cycles, 1);
    } else {
      EXPECT_GT(cycles, 1) << "the larger grid must restart";
    }
  }
}

// CG (symmetric A) keeps a symmetric preconditioner: no zone asked for, the same iterations.
// A preconditioner that is not symmetric (the GMRES V-cycle) makes a symmetric solve GMRES,
// which asks for the zone and converges with it (solve() checks the true residual).
TEST(ZoneCorrection, CgDoesWithoutTheZone) {
  const Solves without = solve(0.0, false, {7});
  const Solves with = solve(0.0, true, {7});
  EXPECT_EQ(with.asked, 0);
  EXPECT_EQ(with.iterations, without.iterations);
  const Solves gmres = solve(0.0, true, {7}, kM, false);
  EXPECT_EQ(gmres.asked, 1) << "a symmetric system with an unsymmetric preconditioner: GMRES";
}

// GMRES gives the preconditioner its basis vectors in place: the k-th call of an unrestarted
// cycle reads column k of the basis, k n doubles after column 0. A `const VectorXd&` there
// made a temporary copy per iteration, which at case 4.4's 160,600 unknowns (1.3 MB) was an
// mmap, 313 page faults and an munmap: 0.2 million page faults in a run.
TEST(ZoneCorrection, GmresPassesItsBasisVectorsWithoutACopy) {
  const Index m = kM, n = m * m;
  auto system = std::make_shared<ZoneSystem>(0.3, true, m);
  auto jacobi = std::make_unique<Jacobi>();
  const Jacobi& seen = *jacobi;
  LinearOptions o;
  o.rtol = 1e-10;
  o.max_iterations = 2000;
  auto solver = make_factor_preconditioned_krylov(std::move(jacobi), FactorSource::preconditioner_matrix, o,
                                                  system, true);
  const SparseMatrix none;
  solver->analyzePattern(none);
  solver->factorize(none);
  solver->configure({false, 1e-10, 7});
  VectorXd x = VectorXd::Zero(n);
  solver->solve(wavy(n, 0.5), x);
  ASSERT_EQ(solver->info(), Eigen::Success);
  const int iterations = solver->stats().iterations;
  ASSERT_GT(iterations, 5);
  ASSERT_LT(iterations, 60) << "one cycle";
  ASSERT_EQ(static_cast<int>(seen.inputs.size()), iterations + 1)
      << "one call per iteration, one for the update";
  for (int k = 1; k < iterations; ++k)
    EXPECT_EQ(seen.inputs[static_cast<std::size_t>(k)] - seen.inputs[0], static_cast<std::ptrdiff_t>(k) * n)
        << "call " << k;
}

}  // namespace
}  // namespace peristat
