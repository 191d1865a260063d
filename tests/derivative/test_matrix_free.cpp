// The matrix-free tangent action (solver.linear: matrix_free, issue 17): apply_tangent(v)
// must be the assembled tangent times v, on every kind of scene the assembled tangent is
// proved on (tests/derivative/test_tangent.cpp, test_contact_tangent.cpp), and the
// directional derivative of the residual.
#include <random>
#include <set>

#include <gtest/gtest.h>
#include <omp.h>

#include "app/setup.hpp"
#include "assembly/quasi_static.hpp"
#include "support/finite_difference.hpp"
#include "support/scenes.hpp"

namespace peristat {
namespace {

using test::random_vector;

struct Pair {
  Scene scene;
  Model model;
  std::unique_ptr<QuasiStaticProblem> assembled, matrix_free;
};

/// The same scene as an assembled and as a matrix-free problem (with `float_factors`, its
/// factors in single precision).
std::unique_ptr<Pair> both(const std::string& yaml, bool float_factors = false, bool float_copy = false) {
  auto p = std::make_unique<Pair>();
  p->scene = test::scene_from_yaml(yaml);
  p->model = discretise(p->scene);
  ProblemOptions options = problem_options(p->scene);
  options.matrix_free = false;
  p->assembled = std::make_unique<QuasiStaticProblem>(p->model, options);
  options.matrix_free = true;
  options.float_factors = float_factors;
  options.float_copy = float_copy;
  p->matrix_free = std::make_unique<QuasiStaticProblem>(p->model, options);
  p->assembled->set_load_factor(1.0);
  p->matrix_free->set_load_factor(1.0);
  return p;
}

/// Evaluates both problems at x with a tangent, then compares K v with apply_tangent(v) for
/// random v. 1e-12 relative: the two sum the same terms in another order (round-off only);
/// `tolerance` for the float factors. Returns K for further checks.
SparseMatrix expect_action_is_the_tangent(Pair& p, const VectorXd& x, double tolerance = 1e-12) {
  SparseMatrix K = p.assembled->make_tangent();
  EXPECT_GT(K.nonZeros(), 0);
  SparseMatrix placeholder = p.matrix_free->make_tangent();
  EXPECT_EQ(placeholder.rows(), 0) << "a matrix-free problem hands out no matrix";
  EXPECT_EQ(p.matrix_free->pattern().nonzeros, 0) << "and builds no pattern";
  VectorXd r_assembled, r_free;
  p.assembled->evaluate(x, r_assembled, &K);
  p.matrix_free->evaluate(x, r_free, &placeholder);
  EXPECT_EQ((r_assembled - r_free).norm(), 0.0) << "the residual is the same computation";
  for (unsigned seed : {1u, 2u, 3u}) {
    const VectorXd v = random_vector(x.size(), 1.0, seed);
    VectorXd y;
    p.matrix_free->apply_tangent(v, y);
    const VectorXd Kv = K * v;
    EXPECT_LT((y - Kv).norm(), tolerance * Kv.norm()) << "seed " << seed;
  }
  return K;
}

std::string cracked_plate(const std::string& kinematics) {
  test::PlateSpec spec;
  spec.nx = 14;
  spec.ny = 10;
  spec.kinematics = kinematics;
  spec.boundary = "  - {body: plate, edge: left, ux: 0, uy: 0}\n  - {body: plate, edge: right, ux: 2.0e-5}\n";
  spec.cracks = "  - {from: [0.004, 0.0031], to: [0.0095, 0.0072]}\n";
  return test::plate_yaml(spec);
}

TEST(MatrixFree, ActionEqualsTheAssembledTangentOnACrackedPlate) {
  for (const char* kinematics : {"finite", "small"}) {
    SCOPED_TRACE(kinematics);
    auto p = both(cracked_plate(kinematics));
    const double dx = p->scene.discretization.spacing;
    expect_action_is_the_tangent(*p, random_vector(p->assembled->n_unknowns(), 0.05 * dx, 7u));
  }
}

/// A matrix-free problem of p's scene and model, at load factor 1.
std::unique_ptr<QuasiStaticProblem> matrix_free_problem(const Pair& p) {
  ProblemOptions options = problem_options(p.scene);
  options.matrix_free = true;
  auto q = std::make_unique<QuasiStaticProblem>(p.model, options);
  q->set_load_factor(1.0);
  return q;
}

/// a's and b's actions on the same vector, bit for bit.
void expect_same_action(QuasiStaticProblem& a, QuasiStaticProblem& b, const char* what) {
  const VectorXd v = random_vector(a.n_unknowns(), 1.0, 9u);
  VectorXd ya, yb;
  a.apply_tangent(v, ya);
  b.apply_tangent(v, yb);
  ASSERT_EQ(ya.size(), yb.size());
  EXPECT_EQ((ya - yb).cwiseAbs().maxCoeff(), 0.0) << what;
}

// With linearised kinematics the families' factors s_b, k_b depend on the bonds alone: an
// evaluation with a tangent at the bonds of the last one keeps them and the pairs'
// stiffnesses made of them (factor_evaluations() does not grow), and its action is bit for bit
// that of a problem that made them at the same state. A round of breaking, and its undoing,
// make them again. With finite kinematics every evaluation with a tangent makes them.
TEST(MatrixFree, KeptFactorsAreTheKernelsBitForBit) {
  auto p = both(cracked_plate("small") + "failure: {criterion: stretch, G_c: 1.0e-3}\n");
  QuasiStaticProblem& kept = *p->matrix_free;
  const double dx = p->scene.discretization.spacing;
  const Index n = kept.n_unknowns();
  SparseMatrix none = kept.make_tangent();
  VectorXd r;
  kept.evaluate(random_vector(n, 0.01 * dx, 1u), r, &none);
  EXPECT_EQ(kept.factor_evaluations(), 1);
  const VectorXd x = random_vector(n, 0.05 * dx, 2u);
  kept.evaluate(x, r, &none);
  EXPECT_EQ(kept.factor_evaluations(), 1) << "the same bonds: the factors are kept";
  const auto intact = matrix_free_problem(*p);
  intact->evaluate(x, r, &none);
  expect_same_action(kept, *intact, "kept");

  // The same random state as Tangent.ConsistentAfterBondsBreak: a few hundred bonds over the
  // small critical stretch.
  const VectorXd x0 = random_vector(n, 0.05 * dx, 11u);
  const Index broke = kept.advance_irreversible_state(x0, 300);
  ASSERT_GT(broke, 50);
  kept.evaluate(x, r, &none);
  EXPECT_EQ(kept.factor_evaluations(), 2) << "bonds broke: the factors are made again";
  const auto broken = matrix_free_problem(*p);
  ASSERT_EQ(broken->advance_irreversible_state(x0, 300), broke);
  broken->evaluate(x, r, &none);
  expect_same_action(kept, *broken, "after a round of breaking");
  kept.evaluate(x0, r, &none);
  EXPECT_EQ(kept.factor_evaluations(), 2);

  kept.revert_irreversible_state();
  kept.evaluate(x, r, &none);
  EXPECT_EQ(kept.factor_evaluations(), 3) << "the round undone: the factors are made again";
  expect_same_action(kept, *intact, "after the round's undoing");

  auto finite = both(cracked_plate("finite"));
  SparseMatrix placeholder = finite->matrix_free->make_tangent();
  for (unsigned seed : {1u, 2u})
    finite->matrix_free->evaluate(random_vector(n, 0.05 * dx, seed), r, &placeholder);
  EXPECT_EQ(finite->matrix_free->factor_evaluations(), 2) << "finite kinematics: made at every evaluation";
}

// A round that breaks a few pairs changes a few families: an evaluation with a tangent then
// makes the factors of those families and the stiffnesses of their pairs only
// (factor_patches()), bit for bit what a problem that made them all at the same bonds applies,
// with double factors and with their float copy; a further round, and its undoing, alike.
TEST(MatrixFree, PatchedFactorsAreTheKernelsBitForBit) {
  for (const bool copy : {false, true}) {
    SCOPED_TRACE(copy ? "float copy" : "double");
    auto p = both(cracked_plate("small") + "failure: {criterion: stretch, G_c: 1.0e-3}\n", false, copy);
    QuasiStaticProblem& kept = *p->matrix_free;
    const double dx = p->scene.discretization.spacing;
    const Index n = kept.n_unknowns();
    SparseMatrix none = kept.make_tangent();
    VectorXd r;
    const VectorXd x = random_vector(n, 0.05 * dx, 2u), x0 = random_vector(n, 0.05 * dx, 11u);
    kept.evaluate(x, r, &none);
    ProblemOptions options = problem_options(p->scene);
    options.matrix_free = true;
    options.float_copy = copy;
    for (const Index rounds : {1, 2}) {
      ASSERT_EQ(kept.advance_irreversible_state(x0, 3), 3);
      kept.evaluate(x, r, &none);
      EXPECT_EQ(kept.factor_evaluations(), 1) << rounds << " rounds of 3 pairs: patched, not made again";
      EXPECT_EQ(kept.factor_patches(), rounds);
      QuasiStaticProblem fresh(p->model, options);
      fresh.set_load_factor(1.0);
      for (Index k = 0; k < rounds; ++k) ASSERT_EQ(fresh.advance_irreversible_state(x0, 3), 3);
      fresh.evaluate(x, r, &none);
      EXPECT_EQ(fresh.factor_patches(), 0);
      expect_same_action(kept, fresh, rounds == 1 ? "after one round" : "after two rounds");
      if (rounds == 1) kept.commit(x0);
    }
    kept.revert_irreversible_state();
    kept.evaluate(x, r, &none);
    EXPECT_EQ(kept.factor_patches(), 3) << "the round undone: patched again";
  }
}

/// A plate held by mirror grips on both ends, one of them pulled.
std::string mirror_gripped_plate() {
  test::PlateSpec spec;
  spec.nx = 18;
  spec.ny = 10;
  spec.boundary = "  - {body: plate, edge: left, mirror: true, ux: 0}\n"
                  "  - {body: plate, edge: right, mirror: true, ux: 2.0e-5}\n"
                  "  - {body: plate, region: {min: [0, 0.004], max: [0.001, 0.006]}, uy: 0}\n";
  return test::plate_yaml(spec);
}

/// mirror_gripped_plate() with linearised kinematics.
std::string mirror_gripped_plate_small() {
  test::PlateSpec spec;
  spec.nx = 18;
  spec.ny = 10;
  spec.kinematics = "small";
  spec.boundary =
      "  - {body: plate, edge: left, mirror: true, ux: 0}\n"
      "  - {body: plate, edge: right, mirror: true, ux: 2.0e-5}\n"
      "  - {body: plate, region: {min: [0, 0.004], max: [0.001, 0.006]}, uy: 0}\n";
  return test::plate_yaml(spec);
}

// Mirror grips: the ghosts' columns fold into their sources' (scatter with the signs).
TEST(MatrixFree, ActionEqualsTheAssembledTangentWithMirrorGrips) {
  auto p = both(mirror_gripped_plate());
  ASSERT_TRUE(p->model.constraints.has_images());
  const double dx = p->scene.discretization.spacing;
  expect_action_is_the_tangent(*p, random_vector(p->assembled->n_unknowns(), 0.05 * dx, 31u));
}

/// r of the matrix-free problem `q` at x without a tangent, against the assembled problem's
/// (which always evaluates the families) at the same state: the residual, every component's
/// internal force (the reactions too), the energy and a stress. With linear bond forces the
/// forces are the kept factors' product H u: the same sums in another order, so equal to
/// round-off (1e-12 relative: measured 2.7e-16 .. 3.0e-16); the energy and the stress are the
/// families' at that state again, bit for bit.
void expect_same_residual(QuasiStaticProblem& q, QuasiStaticProblem& assembled, const VectorXd& x,
                          const char* what) {
  VectorXd r, r_ref;
  q.evaluate(x, r, nullptr);
  assembled.evaluate(x, r_ref, nullptr);
  const double apart = (r - r_ref).norm() / r_ref.norm();
  const double forces_apart =
      (q.internal_force() - assembled.internal_force()).norm() / assembled.internal_force().norm();
  std::printf("%s: residual %.2e, internal forces %.2e apart (relative)\n", what, apart, forces_apart);
  EXPECT_LT(apart, 1e-12) << what;
  EXPECT_LT(forces_apart, 1e-12) << what;
  EXPECT_EQ(q.energy(), assembled.energy()) << what;
  const Index mid = q.model().particles.size() / 2;
  EXPECT_EQ(q.stress(mid), assembled.stress(mid)) << what;
}

// With linearised kinematics the bond forces are linear in u and zero at u = 0: once a
// tangent evaluation has made the action's factors at the current bonds, an evaluation takes
// the forces as their product H u (QuasiStaticProblem::linear_forces()). The same residual,
// reactions, energy and stress as the families' (on a cracked plate, after a round of
// breaking, and with mirror grips, whose ghosts fold into their sources); none before the
// first tangent, none after the bonds changed until the next tangent, never with finite
// kinematics or float factors.
TEST(MatrixFree, LinearBondForcesAreTheFamiliesForces) {
  auto p = both(cracked_plate("small") + "failure: {criterion: stretch, G_c: 1.0e-3}\n");
  QuasiStaticProblem& q = *p->matrix_free;
  const double dx = p->scene.discretization.spacing;
  const Index n = q.n_unknowns();
  VectorXd r;
  q.evaluate(random_vector(n, 0.01 * dx, 1u), r, nullptr);
  EXPECT_EQ(q.linear_force_evaluations(), 0) << "no factors yet";
  SparseMatrix none = q.make_tangent();
  q.evaluate(random_vector(n, 0.01 * dx, 2u), r, &none);
  EXPECT_EQ(q.linear_force_evaluations(), 0) << "the tangent evaluation that makes the factors";
  expect_same_residual(q, *p->assembled, random_vector(n, 0.05 * dx, 3u), "intact");
  EXPECT_EQ(q.linear_force_evaluations(), 1);
  q.evaluate(random_vector(n, 0.05 * dx, 4u), r, &none);
  EXPECT_EQ(q.linear_force_evaluations(), 2) << "a kept tangent takes the linear forces too";

  const VectorXd x0 = random_vector(n, 0.05 * dx, 11u);
  const Index broke = q.advance_irreversible_state(x0, 300);
  ASSERT_GT(broke, 50);
  ASSERT_EQ(p->assembled->advance_irreversible_state(x0, 300), broke);
  expect_same_residual(q, *p->assembled, random_vector(n, 0.05 * dx, 5u), "bonds broke, no tangent since");
  EXPECT_EQ(q.linear_force_evaluations(), 2) << "the factors are the old bonds'";
  q.evaluate(x0, r, &none);
  expect_same_residual(q, *p->assembled, random_vector(n, 0.05 * dx, 6u), "after a round of breaking");
  EXPECT_EQ(q.linear_force_evaluations(), 3);

  auto mirror = both(mirror_gripped_plate_small());
  ASSERT_TRUE(mirror->model.constraints.has_images());
  const Index nm = mirror->matrix_free->n_unknowns();
  SparseMatrix placeholder = mirror->matrix_free->make_tangent();
  mirror->matrix_free->evaluate(VectorXd::Zero(nm), r, &placeholder);
  expect_same_residual(*mirror->matrix_free, *mirror->assembled, random_vector(nm, 0.05 * dx, 7u),
                       "mirror grips");
  EXPECT_EQ(mirror->matrix_free->linear_force_evaluations(), 1);

  for (const bool single : {false, true}) {
    auto other = single ? both(cracked_plate("small"), true) : both(cracked_plate("finite"));
    SparseMatrix t = other->matrix_free->make_tangent();
    other->matrix_free->evaluate(random_vector(n, 0.01 * dx, 1u), r, &t);
    other->matrix_free->evaluate(random_vector(n, 0.01 * dx, 2u), r, nullptr);
    EXPECT_EQ(other->matrix_free->linear_force_evaluations(), 0)
        << (single ? "float factors" : "finite kinematics");
  }
}

// apply_tangent() runs chunks of consecutive families colour by colour, the chunks of a
// colour in parallel, each family adding into its neighbours' rows. The scenes above fit in
// one chunk; here chunks of 16 particles, with mirror ghosts (numbered after the plate, so
// their chunks border chunks far away in the numbering) and a crack.
std::string gripped_cracked_plate() {
  test::PlateSpec spec;
  spec.nx = 30;
  spec.ny = 12;
  spec.boundary =
      "  - {body: plate, edge: left, mirror: true, ux: 0}\n"
      "  - {body: plate, edge: right, mirror: true, ux: 2.0e-5}\n"
      "  - {body: plate, region: {min: [0, 0.005], max: [0.001, 0.007]}, uy: 0}\n";
  spec.cracks = "  - {from: [0.012, 0.003], to: [0.018, 0.009]}\n";
  return test::plate_yaml(spec);
}

// The colouring's promise: the chunks of one colour write disjoint rows (family i writes row
// i and its neighbours' rows), and every chunk runs once. Fails when chunk_colours() keeps
// chunks one stencil reach apart instead of two (checked).
TEST(MatrixFree, ChunksOfAColourWriteDisjointRows) {
  const Model model = discretise(test::scene_from_yaml(gripped_cracked_plate()));
  ASSERT_TRUE(model.constraints.has_images());
  const Index n = model.particles.size();
  for (const Index chunk : {Index{1}, Index{16}, Index{50}}) {
    SCOPED_TRACE(chunk);
    const std::vector<std::vector<Index>> colours = chunk_colours(model, chunk);
    EXPECT_GT(colours.size(), 1u) << "chunks smaller than the model conflict";
    std::set<Index> seen;
    for (const std::vector<Index>& colour : colours) {
      std::vector<int> writer(static_cast<std::size_t>(n), -1);
      for (const Index c : colour) {
        EXPECT_TRUE(seen.insert(c).second) << "chunk " << c << " twice";
        for (Index i = c * chunk; i < std::min(n, (c + 1) * chunk); ++i) {
          std::vector<Index> rows{i};
          for (Index b = model.bonds.start[i]; b < model.bonds.start[i + 1]; ++b)
            rows.push_back(model.bonds.neighbour[b]);
          for (const Index row : rows) {
            int& w = writer[static_cast<std::size_t>(row)];
            EXPECT_TRUE(w < 0 || w == static_cast<int>(c))
                << "row " << row << " written by chunks " << w << " and " << c;
            w = static_cast<int>(c);
          }
        }
      }
    }
    EXPECT_EQ(static_cast<Index>(seen.size()), (n + chunk - 1) / chunk) << "every chunk runs";
  }
}

// With many chunks and colours the action is still the assembled tangent's (1e-12, round-off
// of another summation order), and the same to the last bit on one thread and on two: each
// row sums its terms in an order fixed by the particles (the results do not depend on the
// machine's cores).
TEST(MatrixFree, ActionInSmallChunksIsTheTangentOnAnyNumberOfThreads) {
  auto p = both(gripped_cracked_plate());
  p->matrix_free->set_action_chunk(16);
  const double dx = p->scene.discretization.spacing;
  expect_action_is_the_tangent(*p, random_vector(p->assembled->n_unknowns(), 0.05 * dx, 5u));
  const VectorXd v = random_vector(p->assembled->n_unknowns(), 1.0, 9u);
  const int threads = omp_get_max_threads();
  VectorXd y1, y2;
  omp_set_num_threads(1);
  p->matrix_free->apply_tangent(v, y1);
  omp_set_num_threads(2);
  p->matrix_free->apply_tangent(v, y2);
  omp_set_num_threads(threads);
  EXPECT_GT(y1.norm(), 0.0);
  EXPECT_EQ((y1 - y2).norm(), 0.0) << "one thread against two";
}

// Contact with friction, both stick and slip (the unsymmetric tangent), compressed across a
// cut: the pairs' Jacobians enter the action. Then a residual-only evaluation at another
// state (Newton's first iteration of a step, docs/theory/newton.md "Predictor") must leave the
// action at the tangent of the last state that asked for one, as the assembled matrix is.
/// A plate cut through by a crack, its faces pressed together and sliding (friction 0.2),
/// and a state x at which pairs stick and slip.
struct FrictionalScene {
  std::unique_ptr<Pair> p;
  VectorXd x;
  double dx = 1e-3;
};

FrictionalScene frictional_scene(bool float_factors = false, bool float_copy = false) {
  FrictionalScene f;
  test::PlateSpec spec;
  spec.nx = 12;
  spec.ny = 8;
  spec.dx = f.dx;
  spec.boundary = "  - {body: plate, edge: left, ux: 0, uy: 0}\n";
  spec.cracks = "  - {from: [0.0061, -0.001], to: [0.0061, 0.009]}\n";
  f.p = both(test::plate_yaml(spec) + "contact:\n  friction: 0.2\n  radius_factor: 1.2\n", float_factors,
             float_copy);
  std::mt19937 gen(11);
  std::uniform_real_distribution<double> d(-1.0, 1.0);
  const Model& model = f.p->model;
  f.x.resize(f.p->assembled->n_unknowns());
  for (Index q = 0; q < model.particles.size(); ++q)
    for (int c = 0; c < 2; ++c)
      if (const Index k = model.constraints.free_index[2 * q + c]; k >= 0)
        f.x[k] = (c == 0 ? -0.08 * model.particles.position[q].x() : 0.0) + 0.02 * f.dx * d(gen);
  return f;
}

TEST(MatrixFree, ActionEqualsTheAssembledTangentWithFrictionalContact) {
  FrictionalScene f = frictional_scene();
  Pair* p = f.p.get();
  const VectorXd& x = f.x;
  const double dx = f.dx;
  const Index n = p->assembled->n_unknowns();
  const SparseMatrix K = expect_action_is_the_tangent(*p, x);
  const ContactCounts counts = p->matrix_free->contact()->counts();
  EXPECT_GT(counts.stick, 0);
  EXPECT_GT(counts.slip, 0);
  EXPECT_FALSE(p->matrix_free->traits().tangent_symmetric);

  VectorXd r;
  p->matrix_free->evaluate(x + random_vector(n, 0.01 * dx, 5u), r, nullptr);
  const VectorXd v = random_vector(n, 1.0, 9u);
  VectorXd y;
  p->matrix_free->apply_tangent(v, y);
  EXPECT_LT((y - K * v).norm(), 1e-12 * (K * v).norm()) << "the action moved with a residual-only evaluation";
}

// While a preconditioner is set up the problem may drop the action's per-bond factors
// (suspend_action(), 32 bytes per bond) and compute them again (resume_action()): the action
// must come back bit for bit the tangent's, at the state of the evaluation with the tangent
// even after a residual-only evaluation moved the state (as the predictor's do), with the
// contact pairs' Jacobians of that evaluation (slipping pairs: unsymmetric), and the last
// evaluation's energy and stresses must stay.
TEST(MatrixFree, SuspendedActionComesBackBitForBitAtTheTangentsState) {
  FrictionalScene f = frictional_scene();
  Pair* p = f.p.get();
  const VectorXd& x = f.x;
  const double dx = f.dx;
  QuasiStaticProblem& problem = *p->matrix_free;
  const Index n = problem.n_unknowns();
  SparseMatrix placeholder = problem.make_tangent();
  VectorXd r, y_before, y_after;
  problem.evaluate(x, r, &placeholder);
  EXPECT_GT(problem.contact()->counts().slip, 0);
  const VectorXd v = random_vector(n, 1.0, 9u);
  problem.apply_tangent(v, y_before);
  EXPECT_FALSE(problem.suspend_action()) << "below kSuspendActionBonds the factors stay";

  problem.set_suspend_bonds(0);
  problem.evaluate(x, r, &placeholder);
  problem.set_suspend_bonds(kSuspendActionBonds);
  problem.evaluate(x + random_vector(n, 0.01 * dx, 5u), r, nullptr);
  problem.set_suspend_bonds(0);
  EXPECT_FALSE(problem.suspend_action()) << "the tangent's state was not kept: it cannot come back";

  problem.evaluate(x, r, &placeholder);
  problem.evaluate(x + random_vector(n, 0.01 * dx, 5u), r, nullptr);  // the state moves on
  const double energy = problem.energy();
  const Mat2 stress = problem.stress(p->model.particles.size() / 2);
  const std::size_t held = problem.memory_bytes();
  ASSERT_TRUE(problem.suspend_action());
  const std::size_t bonds = p->model.bonds.neighbour.size();
  EXPECT_GE(held - problem.memory_bytes(), 32 * bonds) << "s_b and k_b are freed";
  EXPECT_THROW(problem.apply_tangent(v, y_after), std::logic_error);
  problem.resume_action();
  problem.apply_tangent(v, y_after);
  ASSERT_EQ(y_after.size(), y_before.size());
  for (Index k = 0; k < n; ++k) ASSERT_EQ(y_after[k], y_before[k]) << "row " << k;
  EXPECT_EQ(problem.energy(), energy);
  EXPECT_EQ(problem.stress(p->model.particles.size() / 2), stress);

  // Suspended, then a new evaluation with a tangent: the factors are that one's.
  ASSERT_TRUE(problem.suspend_action());
  problem.evaluate(x, r, &placeholder);
  problem.apply_tangent(v, y_after);
  for (Index k = 0; k < n; ++k) ASSERT_EQ(y_after[k], y_before[k]) << "row " << k;
}

// The action is the directional derivative of the residual: central differences of r along
// v with h = 1e-7 dx (truncation and round-off about 1e-9 relative; tolerance 1e-6).
TEST(MatrixFree, ActionIsTheDirectionalDerivativeOfTheResidual) {
  auto p = both(cracked_plate("finite"));
  QuasiStaticProblem& problem = *p->matrix_free;
  const double dx = p->scene.discretization.spacing;
  const Index n = problem.n_unknowns();
  const VectorXd x = random_vector(n, 0.05 * dx, 7u);
  for (unsigned seed : {3u, 4u}) {
    const VectorXd v = random_vector(n, 1.0, seed);
    SparseMatrix placeholder = problem.make_tangent();
    VectorXd r, plus, minus, y;
    problem.evaluate(x, r, &placeholder);
    problem.apply_tangent(v, y);
    const double h = 1e-7 * dx;
    problem.evaluate(x + h * v, plus, nullptr);
    problem.evaluate(x - h * v, minus, nullptr);
    const VectorXd difference = (plus - minus) / (2.0 * h);
    EXPECT_LT((y - difference).norm(), 1e-6 * difference.norm()) << "seed " << seed;
  }
}

// solver.krylov.factors float: the action's factors rounded to single precision (relative
// error 6e-8 each), at any spacing, give K v to about that: 2e-6 relative allows the cancellation of a row's
// terms of both signs (the rank-one dilatation term against the bond terms) by a factor 30.
// The product must not be the double one (the float path taken), and a rigid translation must
// keep no action in the rows whose stencils hold no prescribed component: s_self sums the
// rounded s_b, so G_i cancels to round-off in double (1e-12 relative; with s_self from the
// unrounded s_b it would be about 1e-8).
TEST(MatrixFree, FloatFactorsGiveTheTangentToSinglePrecision) {
  struct Case {
    std::string name, yaml;
  };
  // A steel plate of 1e-7 m spacing: unscaled, its pair coefficients (a - g) / |s_b|^2 ~ mu /
  // dx^6 would overflow single precision (1e51); the families' power-of-two scales keep them
  // O(mu).
  test::PlateSpec micro;
  micro.nx = 16;
  micro.ny = 10;
  micro.dx = 1e-7;
  micro.E = 2e11;
  micro.thickness = 1e-7;
  micro.boundary =
      "  - {body: plate, edge: left, ux: 0, uy: 0}\n  - {body: plate, edge: right, ux: 2.0e-9}\n";
  for (const Case& c :
       {Case{"cracked finite", cracked_plate("finite")}, Case{"cracked small", cracked_plate("small")},
        Case{"mirror grips", mirror_gripped_plate()},
        Case{"steel at dx = 1e-7 m", test::plate_yaml(micro)}}) {
    SCOPED_TRACE(c.name);
    auto p = both(c.yaml, true);
    auto exact = both(c.yaml, false);
    const double dx = p->scene.discretization.spacing;
    const VectorXd x = random_vector(p->assembled->n_unknowns(), 0.05 * dx, 7u);
    expect_action_is_the_tangent(*p, x, 2e-6);
    expect_action_is_the_tangent(*exact, x);
    const VectorXd v = random_vector(x.size(), 1.0, 4u);
    VectorXd y_float, y_double;
    p->matrix_free->apply_tangent(v, y_float);
    exact->matrix_free->apply_tangent(v, y_double);
    EXPECT_GT((y_float - y_double).norm(), 1e-10 * y_double.norm()) << "the factors were not rounded";

    // A rigid translation along x on the unknowns: rows two horizons from any prescribed
    // component (or mirror ghost) see the whole translation.
    const Model& model = p->model;
    const Constraints& cons = model.constraints;
    VectorXd t = VectorXd::Zero(x.size());
    for (Index q = 0; q < model.particles.size(); ++q)
      if (cons.free_index[2 * q] >= 0) t[cons.free_index[2 * q]] = 1.0;
    VectorXd y;
    p->matrix_free->apply_tangent(t, y);
    const double reach = 2.0 * model.horizon + 1e-9 * dx;
    double largest = 0.0, scale = 0.0;
    int interior = 0;
    for (Index q = 0; q < model.particles.size(); ++q) {
      const Index k = cons.free_index[2 * q];
      if (k < 0) continue;
      scale = std::max(scale, std::abs(y_double[k]));
      bool whole = true;
      for (Index o = 0; o < model.particles.size() && whole; ++o)
        if ((model.particles.position[o] - model.particles.position[q]).norm() <= reach)
          whole = cons.free_index[2 * o] >= 0 && cons.free_index[2 * o + 1] >= 0;
      if (!whole) continue;
      ++interior;
      largest = std::max({largest, std::abs(y[k]), std::abs(y[cons.free_index[2 * q + 1]])});
    }
    ASSERT_GT(interior, 0) << "no row away from the boundary conditions";
    EXPECT_LT(largest, 1e-12 * scale) << interior << " interior rows";
  }
}

// The float factors with frictional contact (slipping pairs: an unsymmetric tangent; the
// pairs' Jacobians stay double): the action is the tangent to single precision (as above), and
// suspending the factors frees 16 bytes per bond and brings them back bit for bit.
TEST(MatrixFree, FloatFactorsWithFrictionalContactComeBackAfterASuspension) {
  FrictionalScene f = frictional_scene(true);
  QuasiStaticProblem& problem = *f.p->matrix_free;
  expect_action_is_the_tangent(*f.p, f.x, 2e-6);
  EXPECT_GT(problem.contact()->counts().slip, 0);
  const Index n = problem.n_unknowns();
  SparseMatrix placeholder = problem.make_tangent();
  VectorXd r, y_before, y_after;
  problem.set_suspend_bonds(0);
  problem.evaluate(f.x, r, &placeholder);
  const VectorXd v = random_vector(n, 1.0, 9u);
  problem.apply_tangent(v, y_before);
  problem.evaluate(f.x + random_vector(n, 0.01 * f.dx, 5u), r, nullptr);  // the state moves on
  const std::size_t held = problem.memory_bytes();
  ASSERT_TRUE(problem.suspend_action());
  const std::size_t bonds = f.p->model.bonds.neighbour.size();
  EXPECT_GE(held - problem.memory_bytes(), 16 * bonds) << "s_b and k_b in float are freed";
  EXPECT_LT(held - problem.memory_bytes(), 32 * bonds) << "and they took 16 bytes per bond, not 32";
  problem.resume_action();
  problem.apply_tangent(v, y_after);
  ASSERT_EQ(y_after.size(), y_before.size());
  for (Index k = 0; k < n; ++k) ASSERT_EQ(y_after[k], y_before[k]) << "row " << k;
}

// solver.krylov.factors mixed (the default with frictional contact): the action reads a float
// copy of the double factors, so it is the tangent to single precision (2e-6, as float
// factors) and not the double product, while the residual stays the double one (the
// kernels', or with linearised kinematics the double factors' product): the same bits as
// without the copy. Suspending the factors frees the copy too (48 bytes per bond
// in all) and brings the product back bit for bit.
TEST(MatrixFree, MixedFactorsActOnTheFloatCopyAndKeepTheResidualDouble) {
  FrictionalScene f = frictional_scene(false, true);
  FrictionalScene d = frictional_scene();
  QuasiStaticProblem& problem = *f.p->matrix_free;
  expect_action_is_the_tangent(*f.p, f.x, 2e-6);
  EXPECT_GT(problem.contact()->counts().slip, 0);
  const Index n = problem.n_unknowns();
  SparseMatrix placeholder = problem.make_tangent(), placeholder_d = d.p->matrix_free->make_tangent();
  VectorXd r, r_double, y_before, y_double, y_after;
  problem.set_suspend_bonds(0);
  problem.evaluate(f.x, r, &placeholder);
  d.p->matrix_free->evaluate(f.x, r_double, &placeholder_d);
  const VectorXd v = random_vector(n, 1.0, 9u);
  problem.apply_tangent(v, y_before);
  d.p->matrix_free->apply_tangent(v, y_double);
  EXPECT_GT((y_before - y_double).norm(), 1e-10 * y_double.norm()) << "the copy was not read";
  const VectorXd moved = f.x + random_vector(n, 0.01 * f.dx, 5u);  // the state moves on
  problem.evaluate(moved, r, nullptr);
  d.p->matrix_free->evaluate(moved, r_double, nullptr);
  ASSERT_EQ(r.size(), r_double.size());
  for (Index k = 0; k < n; ++k) ASSERT_EQ(r[k], r_double[k]) << "residual row " << k;
  const std::size_t held = problem.memory_bytes();
  ASSERT_TRUE(problem.suspend_action());
  const std::size_t bonds = f.p->model.bonds.neighbour.size();
  EXPECT_GE(held - problem.memory_bytes(), 48 * bonds) << "s_b and k_b in double and their float copy";
  problem.resume_action();
  problem.apply_tangent(v, y_after);
  ASSERT_EQ(y_after.size(), y_before.size());
  for (Index k = 0; k < n; ++k) ASSERT_EQ(y_after[k], y_before[k]) << "row " << k;
}

}  // namespace
}  // namespace peristat
