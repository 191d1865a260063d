// The parallel assembly is deterministic: one thread and two threads give bit-identical
// residuals and tangents (each entry is summed by one thread in a fixed order).
#include <algorithm>
#include <atomic>
#include <functional>
#include <limits>
#include <random>
#include <tuple>

#include <gtest/gtest.h>
#include <omp.h>

#include "app/setup.hpp"
#include "assembly/quasi_static.hpp"
#include "parallel/thread_ranks.hpp"
#include "support/owners.hpp"
#include "support/finite_difference.hpp"
#include "support/scenes.hpp"
#include "support/solve.hpp"

namespace peristat {
namespace {

TEST(Assembly, BitIdenticalForAnyThreadCount) {
  test::PlateSpec spec;
  spec.nx = 24;
  spec.ny = 14;
  spec.boundary = "  - {body: plate, edge: left, ux: 0, uy: 0}\n  - {body: plate, edge: right, ux: 1.0e-5}\n";
  spec.cracks = "  - {from: [0.008, 0.004], to: [0.014, 0.01]}\n";
  const Scene scene = test::scene_from_yaml(test::plate_yaml(spec));
  const Model model = discretise(scene);
  QuasiStaticProblem problem(model, problem_options(scene));
  problem.set_load_factor(1.0);
  std::mt19937 gen(5);
  std::uniform_real_distribution<double> d(-1e-5, 1e-5);
  VectorXd x(problem.n_unknowns());
  for (Index i = 0; i < x.size(); ++i) x[i] = d(gen);

  const int saved = omp_get_max_threads();
  SparseMatrix K1 = problem.make_tangent(), K2 = problem.make_tangent();
  SparseMatrix P1 = problem.make_preconditioner(), P2 = problem.make_preconditioner();
  VectorXd r1, r2;
  omp_set_num_threads(1);
  problem.evaluate(x, r1, &K1);
  problem.assemble_preconditioner(P1);
  omp_set_num_threads(2);
  problem.evaluate(x, r2, &K2);
  problem.assemble_preconditioner(P2);
  omp_set_num_threads(saved);

  ASSERT_EQ(K1.nonZeros(), K2.nonZeros());
  EXPECT_TRUE((r1.array() == r2.array()).all());
  EXPECT_TRUE(std::equal(K1.valuePtr(), K1.valuePtr() + K1.nonZeros(), K2.valuePtr()));
  EXPECT_TRUE(std::equal(P1.valuePtr(), P1.valuePtr() + P1.nonZeros(), P2.valuePtr()));
  EXPECT_GT(r1.norm(), 0.0);  // a non-trivial state
}

// The second make_tangent() rebuilds the same pattern the first one handed over.
TEST(Assembly, RebuiltPatternEqualsTheFirst) {
  test::PlateSpec spec;
  spec.nx = 10;
  spec.ny = 8;
  spec.boundary = "  - {body: plate, edge: left, ux: 0, uy: 0}\n";
  const Scene scene = test::scene_from_yaml(test::plate_yaml(spec));
  const Model model = discretise(scene);
  QuasiStaticProblem problem(model, problem_options(scene));
  const SparseMatrix a = problem.make_tangent(), b = problem.make_tangent();
  ASSERT_EQ(a.nonZeros(), b.nonZeros());
  EXPECT_TRUE(std::equal(a.innerIndexPtr(), a.innerIndexPtr() + a.nonZeros(), b.innerIndexPtr()));
  EXPECT_TRUE(std::equal(a.outerIndexPtr(), a.outerIndexPtr() + a.outerSize() + 1, b.outerIndexPtr()));
}

// The `block` selector adds fictitious particles at the free lattice points of its box (the
// paper's fixed 3 x 3 corner block of case 4.4) and refuses a box that reaches into a body.
TEST(Discretise, ABondThroughACrackTipIsCutBothWaysOrNeither) {
  // The bond from (5.5, 5.5) mm to (4.5, 7.5) mm passes exactly through the crack's tip
  // (5.1, 6.3) mm. Computed from each end, round-off put the crossing on either side of the
  // tip: the bond was cut in one direction only and the other's reverse named a wrong bond
  // (found by unit.ModelPart). The test is exact: a property of the geometry, not of a tolerance.
  const Vec2 p(0.0055, 0.0055), q(0.0045, 0.0075), a(0.0051, 0.0063), b(0.0187, 0.0297);
  EXPECT_EQ(bond_crosses_crack(p, q, a, b), bond_crosses_crack(q, p, a, b));
  EXPECT_EQ(bond_crosses_crack(p, q, b, a), bond_crosses_crack(q, p, b, a));
  test::PlateSpec spec;
  spec.nx = 24;
  spec.ny = 36;
  spec.boundary = "  - {body: plate, edge: left, ux: 0, uy: 0}\n";
  spec.cracks = "  - {from: [0.0051, 0.0063], to: [0.0187, 0.0297]}\n";
  const Model model = discretise(test::scene_from_yaml(test::plate_yaml(spec)));
  ASSERT_GT(model.n_cut_bonds, 0);
  const Bonds& bonds = model.bonds;
  for (Index i = 0; i < model.particles.size(); ++i)
    for (Index k = bonds.start[i]; k < bonds.start[i + 1]; ++k) {
      const Index r = bonds.reverse[k];
      ASSERT_GE(r, 0);
      ASSERT_EQ(bonds.neighbour[r], i) << "the reverse of bond " << k << " ends at its particle";
      ASSERT_EQ(bonds.reverse[r], k);
    }
}

TEST(Discretise, BlockSelectorAddsTheFreeLatticePointsOfItsBox) {
  test::PlateSpec spec;
  spec.nx = 10;
  spec.ny = 8;  // plate [0, 0.01] x [0, 0.008], lattice points at (i + 1/2) mm
  spec.boundary =
      "  - {body: plate, edge: bottom, uy: 0}\n"
      "  - {body: plate, block: {min: [0.010, -0.003], max: [0.013, 0.0]}, ux: 0, uy: 0}\n";
  const Scene scene = test::scene_from_yaml(test::plate_yaml(spec));
  const Model model = discretise(scene);
  const Particles& p = model.particles;
  int in_block = 0;
  for (Index q = 0; q < p.size(); ++q) {
    if (p.position[q].x() > 0.010 && p.position[q].y() < 0.0) {
      ++in_block;
      EXPECT_TRUE(p.fictitious[q]);
      EXPECT_TRUE(model.constraints.prescribed[2 * q] && model.constraints.prescribed[2 * q + 1]);
    }
  }
  EXPECT_EQ(in_block, 9);  // x = 10.5, 11.5, 12.5 mm; y = -0.5, -1.5, -2.5 mm

  spec.boundary = "  - {body: plate, block: {min: [0.008, -0.003], max: [0.013, 0.0015]}, ux: 0}\n";
  EXPECT_THROW(discretise(test::scene_from_yaml(test::plate_yaml(spec))), InputError);
}

// A rank of a distributed run assembles its own rows only (ProblemOptions::rows,
// docs/guide/distributed.md): on 2 and 3 ranks, strips or parts cut across x, every rank's tangent and bond
// preconditioner must hold exactly the whole matrices' entries in its rows, bit for bit (the
// same kernels add the same terms in the same order, only the other rows are dropped), and
// the strips together every entry. The scenes reach every branch of the column writer: a
// notched plate with failure, contact between the faces of broken bonds and a held fragment
// (whose diagonal is the largest over the ranks), and a plate between mirror grips.
struct RankedMatrices {
  SparseMatrix K, P;
  VectorXd r;
  double scale = 0.0;  ///< force_scale() of the whole evaluation
  /// With the rows split (distributed ADR, EvaluationMode::own_rows_only): the residual
  /// of the own rows only, its force scale, and the whole residual evaluated after it again;
  /// the own rows again from x with NaN outside residual_reads(), and how many entries those are.
  VectorXd own_r, r_after, own_r_from_reads;
  Index reads = 0;
  double own_scale = 0.0;
};

// Puts the problem in the test's state: x, and (with failure) the bonds that break at x.
using Prepare = std::function<void(QuasiStaticProblem&)>;

RankedMatrices assemble(const Model& model, ProblemOptions options, const Prepare& prepare, const VectorXd& x,
                        const Ranks& ranks = serial_ranks()) {
  QuasiStaticProblem problem(model, options, ranks);
  prepare(problem);
  RankedMatrices m;
  m.K = problem.make_tangent();
  m.P = problem.make_preconditioner();
  problem.evaluate(x, m.r, &m.K);
  m.scale = problem.force_scale();
  problem.assemble_preconditioner(m.P);
  if (problem.set_evaluation_mode(EvaluationMode::own_rows_only)) {
    // First elsewhere, so that a family the own rows need and that is not computed holds
    // another state's values (the whole evaluation above left x's in every family).
    problem.set_evaluation_mode(EvaluationMode::standard);
    problem.evaluate(1.7 * x, m.own_r, nullptr);
    problem.set_evaluation_mode(EvaluationMode::own_rows_only);
    problem.evaluate(x, m.own_r, nullptr);
    m.own_scale = problem.force_scale();
    // Distributed ADR shares only these entries between its steps (GhostExchange).
    const std::vector<Index> reads = problem.residual_reads();
    m.reads = static_cast<Index>(reads.size());
    VectorXd ghosts_only = VectorXd::Constant(x.size(), std::numeric_limits<double>::quiet_NaN());
    for (const Index f : reads) ghosts_only[f] = x[f];
    problem.evaluate(ghosts_only, m.own_r_from_reads, nullptr);
    problem.set_evaluation_mode(EvaluationMode::standard);
    problem.evaluate(x, m.r_after, nullptr);
  }
  return m;
}

// Entries of `part` equal `whole`'s in the rows of [first, end) (unknown rows of those
// particles), and `part` holds nothing else. Returns the entries compared.
long long expect_rows_of(const SparseMatrix& whole, const SparseMatrix& part, const std::vector<char>& mine,
                         const char* what) {
  long long compared = 0;
  EXPECT_EQ(whole.rows(), part.rows());
  EXPECT_EQ(whole.cols(), part.cols());
  for (Index col = 0; col < whole.outerSize(); ++col) {
    SparseMatrix::InnerIterator w(whole, col), p(part, col);
    for (; w; ++w) {
      if (!mine[w.row()]) continue;
      if (!p || p.row() != w.row()) {
        ADD_FAILURE() << what << ": entry (" << w.row() << ", " << col << ") missing from the rank's matrix";
        return compared;
      }
      EXPECT_EQ(p.value(), w.value()) << what << " (" << w.row() << ", " << col << ")";
      ++p;
      ++compared;
    }
    EXPECT_FALSE(p) << what << ": the rank's matrix holds (" << p.row() << ", " << col << ") beyond its rows";
  }
  return compared;
}

// `small`: a plate of at most four horizons across, where a rank's ghosts (two horizons) may be
// every particle.
void expect_ranks_hold_the_whole(const Scene& scene, const Model& model, const Prepare& prepare,
                                 const VectorXd& x, bool cuts_differ = false, bool small = false) {
  const RankedMatrices whole = assemble(model, problem_options(scene), prepare, x);
  ASSERT_GT(whole.r.norm(), 0.0);
  // The matrix-free tangent action at x (solver.belos.tangent: matrix_free): a rank computes
  // its rows only, bit for bit the whole action's (the same loops over the same families),
  // from the entries of v at action_reads() alone (the others NaN here: Belos sends a rank
  // only those), and those are fewer than all.
  const VectorXd direction = test::random_vector(model.constraints.n_free, 1.0, 31u);
  const auto action = [&](ProblemOptions options) {
    options.matrix_free = true;
    QuasiStaticProblem problem(model, options);  // one rank's rows, alone: its collectives are its own values
    prepare(problem);
    SparseMatrix none;
    VectorXd r, y;
    problem.evaluate(x, r, &none);
    const std::vector<Index> reads = problem.action_reads();
    VectorXd v = VectorXd::Constant(direction.size(), std::numeric_limits<double>::quiet_NaN());
    for (const Index f : reads) v[f] = direction[f];
    if (options.rows.all()) {
      EXPECT_EQ(static_cast<Index>(reads.size()), direction.size()) << "one process reads every entry";
    } else if (!small) {
      EXPECT_LT(static_cast<Index>(reads.size()), direction.size())
          << "a rank reads its ghosts, not everything";
    }
    problem.apply_tangent(v, y);
    return y;
  };
  const VectorXd whole_action = action(problem_options(scene));
  ASSERT_GT(whole_action.norm(), 0.0);
  const std::vector<Index>& free = model.constraints.free_index;
  for (const auto& [cuts, ranks] :
       {std::pair{false, 2}, std::pair{false, 3}, std::pair{true, 2}, std::pair{true, 3}}) {
    SCOPED_TRACE(std::string(cuts ? "cuts across x" : "strips") + " on " + std::to_string(ranks) + " ranks");
    // Strips (strip_owners), or parts cut across x at equal counts, as RCB's first cut of a
    // plate longer in x (Zoltan2 starts MPI, which these unit tests, run under the
    // sanitizers, do not; verification.Partition runs RCB itself).
    const std::vector<int> owner =
        cuts ? test::x_cut_owners(model, ranks) : strip_owners(model.constraints, ranks);
    const auto owners = [&](int rank) { return OwnedRows{rank, owner}; };
    if (cuts && cuts_differ) {
      EXPECT_NE(owner, strip_owners(model.constraints, ranks)) << "the cuts are not the strips here";
    }
    // The ranks emulated by threads: each assembles its rows with the others' collectives.
    std::vector<RankedMatrices> parts(static_cast<std::size_t>(ranks));
    ThreadNet net(ranks);
    net.run([&](const ThreadRanks& on) {
      ProblemOptions options = problem_options(scene);
      options.rows = owners(on.rank());
      parts[static_cast<std::size_t>(on.rank())] = assemble(model, options, prepare, x, on);
    });
    long long k_entries = 0, p_entries = 0;
    Index all_rows = 0;
    for (int rank = 0; rank < ranks; ++rank) {
      ProblemOptions options = problem_options(scene);
      options.rows = owners(rank);
      const RankedMatrices& part = parts[static_cast<std::size_t>(rank)];
      std::vector<char> mine(static_cast<std::size_t>(whole.K.rows()), 0);
      Index rows = 0;
      for (Index c = 0; c < static_cast<Index>(free.size()); ++c)
        if (free[c] >= 0 && options.rows.contains(c / 2)) {
          mine[free[c]] = 1;
          ++rows;
        }
      EXPECT_GT(rows, 0) << "rank " << rank << " of " << ranks << " owns rows";
      all_rows += rows;
      EXPECT_TRUE((part.r.array() == whole.r.array()).all()) << "the residual stays whole on every rank";
      // Own rows only (distributed ADR): the rank's rows bit for bit, zero elsewhere; the force
      // scale over every component, its squares summed rank by rank instead of in one pass
      // (round-off: 1e-14 relative); the whole residual again once switched off.
      ASSERT_EQ(part.own_r.size(), whole.r.size()) << "a rank's problem evaluates its own rows";
      for (Index f = 0; f < whole.r.size(); ++f)
        EXPECT_EQ(part.own_r[f], mine[f] ? whole.r[f] : 0.0) << "unknown " << f << (mine[f] ? " (own)" : "");
      EXPECT_NEAR(part.own_scale, whole.scale, 1e-14 * whole.scale);
      EXPECT_TRUE((part.own_r_from_reads.array() == part.own_r.array()).all())
          << "the own rows read x only at residual_reads()";
      if (!small && (rank == 0 || rank == ranks - 1)) {  // (a middle rank of a narrow plate may read all)
        EXPECT_LT(part.reads, whole.r.size()) << "an outer rank reads its ghosts, not everything";
      }
      EXPECT_TRUE((part.r_after.array() == whole.r.array()).all()) << "whole again after own rows only";
      const VectorXd y = action(options);
      for (Index f = 0; f < whole.r.size(); ++f)
        EXPECT_EQ(y[f], mine[f] ? whole_action[f] : 0.0)
            << "action, unknown " << f << (mine[f] ? " (own)" : "");
      const long long k = expect_rows_of(whole.K, part.K, mine, "tangent");
      const long long pc = expect_rows_of(whole.P, part.P, mine, "bond preconditioner");
      EXPECT_EQ(part.K.nonZeros(), k) << "the rank stores its rows only";
      EXPECT_EQ(part.P.nonZeros(), pc) << "the rank stores its rows only";
      k_entries += k;
      p_entries += pc;
    }
    EXPECT_EQ(all_rows, whole.K.rows()) << "the strips own every row once";
    EXPECT_EQ(k_entries, whole.K.nonZeros()) << "the ranks hold every entry of the tangent";
    EXPECT_EQ(p_entries, whole.P.nonZeros()) << "the ranks hold every entry of the preconditioner";
  }
}

// Partitioned bonds (solver.belos.bonds: partitioned): each rank's model holds the families
// families_to_hold() names, and its problem evaluates its rows and those without a row, then
// shares the forces. On every rank the residual and the force scale must be the whole model's
// bit for bit (each force is computed by one rank with the same loops), the energy its sum in
// another order (round-off: 1e-13 relative), and the rank must hold fewer bonds than the model.
// One ring (Newton's matrix-free tangent): the action's and the bond matrix's rows the whole
// model's to the bit. Two rings (an assembled tangent: belos `assembled`, ADR's density): the
// tangent's rows the whole one's to the bit, and ADR's own-rows residual its rows, zero elsewhere.
void expect_partitioned_ranks_equal_the_whole(const Scene& scene, const Model& model, const Prepare& prepare,
                                              const VectorXd& x) {
  const VectorXd direction = test::random_vector(model.constraints.n_free, 1.0, 41u);
  for (const int rings : {1, 2}) {
    SCOPED_TRACE(std::to_string(rings) + " ring(s)");
    ProblemOptions whole_options = problem_options(scene);
    whole_options.matrix_free = rings == 1;
    QuasiStaticProblem whole(model, whole_options);
    prepare(whole);
    SparseMatrix whole_K = whole.make_tangent();
    VectorXd whole_r, whole_y;
    whole.evaluate(x, whole_r, &whole_K);
    ASSERT_GT(whole_r.norm(), 0.0);
    if (rings == 1) whole.apply_tangent(direction, whole_y);
    SparseMatrix whole_P = whole.make_preconditioner();
    whole.assemble_preconditioner(whole_P);
    // Owners of the nodes only (the particles without a row computed by every rank), and of
    // every particle (complete_owners(), as a run's: each computed by one rank).
    for (const auto& [cuts, ranks, complete] :
         {std::tuple{false, 2, false}, std::tuple{false, 3, false}, std::tuple{true, 2, false},
          std::tuple{true, 3, false}, std::tuple{false, 3, true}, std::tuple{true, 2, true}}) {
      SCOPED_TRACE(std::string(cuts ? "cuts across x" : "strips") + " on " + std::to_string(ranks) +
                   " ranks" + (complete ? ", every particle owned" : ""));
      std::vector<int> owner =
          cuts ? test::x_cut_owners(model, ranks) : strip_owners(model.constraints, ranks);
      if (complete) complete_owners(model, owner);
      std::atomic<int> fewer = 0;  // ranks holding fewer bonds than the model
      ThreadNet net(ranks);
      net.run([&](const ThreadRanks& on) {
        const int rank = on.rank();
        const OwnedRows rows{rank, owner};
        const Model part = discretise(scene, [&](const Model& m) { return families_to_hold(m, rows, rings); });
        ASSERT_FALSE(part.holds_every_family());
        // (A middle rank of a narrow plate may hold every family within two rings.)
        EXPECT_LE(part.bonds.n_bonds(), model.bonds.n_bonds());
        fewer += part.bonds.n_bonds() < model.bonds.n_bonds();
        EXPECT_EQ(part.n_bonds_whole, model.bonds.n_bonds()) << "the whole model's count";
        EXPECT_EQ(part.n_cut_bonds, model.n_cut_bonds);
        ProblemOptions options = whole_options;
        options.rows = rows;
        QuasiStaticProblem problem(part, options, on);
        prepare(problem);
        SparseMatrix K = problem.make_tangent();
        VectorXd r, y, own_r;
        // First at another state, so that a family not evaluated here would hold stale values.
        problem.evaluate(1.7 * x, r, &K);
        problem.evaluate(x, r, &K);
        const double scale = problem.force_scale(), energy = problem.energy();
        SparseMatrix P = problem.make_preconditioner();
        problem.assemble_preconditioner(P);
        if (rings == 2) {  // distributed ADR's steps: its rows only, no exchange
          ASSERT_TRUE(problem.set_evaluation_mode(EvaluationMode::own_rows_only));
          problem.evaluate(x, own_r, nullptr);
          problem.set_evaluation_mode(EvaluationMode::standard);
        }
        EXPECT_TRUE((r.array() == whole_r.array()).all()) << "rank " << rank << ": the whole residual";
        EXPECT_EQ(scale, whole.force_scale());
        EXPECT_NEAR(energy, whole.energy(), 1e-13 * std::abs(whole.energy()));
        std::vector<char> mine(static_cast<std::size_t>(whole_r.size()), 0);
        const std::vector<Index>& free = model.constraints.free_index;
        for (Index c = 0; c < static_cast<Index>(free.size()); ++c)
          if (free[c] >= 0 && rows.contains(c / 2)) mine[free[c]] = 1;
        const long long entries = expect_rows_of(whole_P, P, mine, "bond preconditioner");
        EXPECT_EQ(P.nonZeros(), entries) << "the rank stores its rows only";
        if (rings == 1) {
          VectorXd v = VectorXd::Constant(direction.size(), std::numeric_limits<double>::quiet_NaN());
          for (const Index f : problem.action_reads()) v[f] = direction[f];
          problem.apply_tangent(v, y);
          for (Index f = 0; f < whole_r.size(); ++f)
            EXPECT_EQ(y[f], mine[f] ? whole_y[f] : 0.0) << "action, unknown " << f << (mine[f] ? " (own)" : "");
        } else {
          const long long k = expect_rows_of(whole_K, K, mine, "tangent");
          EXPECT_EQ(K.nonZeros(), k) << "the rank stores its rows only";
          for (Index f = 0; f < whole_r.size(); ++f)
            EXPECT_EQ(own_r[f], mine[f] ? whole_r[f] : 0.0) << "own rows, unknown " << f;
        }
      });
      EXPECT_GE(fewer, ranks - 1) << "the outer ranks hold some families only";
    }
  }
}

TEST(Assembly, OwnedRowsAreTheWholeMatricesRows) {
  // The notched plate (40 x 20 mm) with failure and contact; one particle moved by 10 dx
  // breaks every bond of its family (verification.Fragments) and is held as a fragment, and
  // its broken bonds become contact candidates. The particle sits next to the cut of two
  // parts (x = 20 mm, where RCB cuts too), and the matrices are evaluated with it back home, where its pairs
  // with its former neighbours on both sides of the cut are closed (contact radius 1.2 dx): its row then has
  // entries in the other rank's columns, which must be zero like the rest of it.
  const Scene scene = test::scene_from_yaml(
      test::notch_yaml(2e-5, true, "{linear: umfpack}", "contact: {friction: 0.3, radius_factor: 1.2}\n"));
  const Model model = discretise(scene);
  const Particles& p = model.particles;
  Index moved = -1;
  for (Index i = 0; i < p.size(); ++i)
    if (!p.fictitious[i] && (p.position[i] - Vec2(0.0205, 0.0155)).norm() < 1e-4) moved = i;
  ASSERT_GE(moved, 0);
  VectorXd held = VectorXd::Zero(model.constraints.n_free);
  held[model.constraints.free_index[2 * moved]] = 1e-2;
  const Prepare prepare = [&](QuasiStaticProblem& problem) {
    problem.set_load_factor(0.0);
    while (problem.advance_irreversible_state(held) > 0) problem.commit(held);
    problem.set_load_factor(1.0);
  };
  VectorXd x = test::random_vector(model.constraints.n_free, 1e-6, 21u);
  x[model.constraints.free_index[2 * moved]] = -1e-4;  // 0.1 dx towards its left neighbour, on the other part
  {
    QuasiStaticProblem probe(model, problem_options(scene));
    prepare(probe);
    ASSERT_EQ(probe.fragment_particles(), 1);
    ASSERT_NE(probe.contact(), nullptr);
    ASSERT_GT(probe.contact()->size(), 0) << "broken bonds are contact candidates";
    SparseMatrix K = probe.make_tangent();
    VectorXd r;
    probe.evaluate(x, r, &K);
    ASSERT_GT(probe.fragment_contacts(), 0) << "the fragment's pairs carry forces at x";
  }
  expect_ranks_hold_the_whole(scene, model, prepare, x, true);
}

TEST(Assembly, OwnedRowsWithMirrorGrips) {
  test::PlateSpec spec;
  spec.nx = 30;
  spec.ny = 12;
  spec.boundary = test::mirror_tension_boundary(1e-3, spec);
  const Scene scene = test::scene_from_yaml(test::plate_yaml(spec));
  const Model model = discretise(scene);
  ASSERT_TRUE(model.constraints.has_images());
  const Prepare prepare = [](QuasiStaticProblem& problem) { problem.set_load_factor(1.0); };
  const VectorXd x = test::random_vector(model.constraints.n_free, 1e-6, 22u);
  expect_ranks_hold_the_whole(scene, model, prepare, x);
  expect_partitioned_ranks_equal_the_whole(scene, model, prepare, x);
}

// A plate of nx x ny particles cut through by a vertical crack at x = crack_x and compressed
// across it (derivative.ContactTangent), held on its left edge by fictitious layers, with
// contact radius 1.6 dx (diagonal pairs close too). Returns the scene, and at x a state in
// which some pairs stick and some slip.
struct CrackedPlate {
  Scene scene;
  Model model;
  VectorXd x;
};

CrackedPlate compressed_cracked_plate(int nx, int ny, double crack_x, double squeeze, unsigned seed) {
  test::PlateSpec spec;
  spec.nx = nx;
  spec.ny = ny;
  spec.boundary = "  - {body: plate, edge: left, ux: 0, uy: 0}\n";
  spec.cracks = "  - {from: [" + std::to_string(crack_x) + ", -0.001], to: [" + std::to_string(crack_x) +
                ", " + std::to_string((ny + 1) * spec.dx) + "]}\n";
  CrackedPlate c{
      test::scene_from_yaml(test::plate_yaml(spec) + "contact:\n  friction: 0.2\n  radius_factor: 1.6\n"),
      {},
      {}};
  c.model = discretise(c.scene);
  c.x = test::random_vector(c.model.constraints.n_free, 0.02 * spec.dx, seed);
  for (Index p = 0; p < c.model.particles.size(); ++p)
    if (const Index k = c.model.constraints.free_index[2 * p]; k >= 0)
      c.x[k] -= squeeze * c.model.particles.position[p].x();
  QuasiStaticProblem probe(c.model, problem_options(c.scene));
  probe.set_load_factor(1.0);
  SparseMatrix K = probe.make_tangent();
  VectorXd r;
  probe.evaluate(c.x, r, &K);
  const ContactCounts counts = probe.contact()->counts();
  EXPECT_GT(counts.stick, 0);
  EXPECT_GT(counts.slip, 0);
  return c;
}

TEST(Assembly, OwnedRowsWithContactAcrossTheStrips) {
  // The pairs across the crack join particles of two ranks wherever a strip or cut boundary
  // meets the crack.
  const CrackedPlate c = compressed_cracked_plate(12, 8, 0.0061, 0.08, 23u);
  const Prepare prepare = [](QuasiStaticProblem& problem) { problem.set_load_factor(1.0); };
  expect_ranks_hold_the_whole(c.scene, c.model, prepare, c.x, false, true);
}

TEST(Assembly, PartitionedBondsWithContactAcrossTheParts) {
  // 40 x 16, the crack near the middle, where the cuts across x fall on two ranks: the
  // contact pairs join particles of two ranks; the grip's particles have no row, and every
  // rank computes their forces.
  const CrackedPlate c = compressed_cracked_plate(40, 16, 0.0201, 0.04, 24u);
  const Prepare prepare = [](QuasiStaticProblem& problem) { problem.set_load_factor(1.0); };
  expect_partitioned_ranks_equal_the_whole(c.scene, c.model, prepare, c.x);
}

}  // namespace
}  // namespace peristat
