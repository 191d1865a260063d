// The partitioned model's stage 2 pieces under MPI (run by ctest as `mpirun -n 2`; label mpi):
// the ghost exchange by global ids and a Belos solve over the unknowns of each rank's part
// of the model (ModelPart), against one process's CHOLMOD solve of the whole model.
#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <string>

#include <Eigen/CholmodSupport>
#include <gtest/gtest.h>

#include "app/linear_solvers.hpp"
#include "app/setup.hpp"
#include "app/whole_view.hpp"
#include "assembly/quasi_static.hpp"
#include "discretisation/model_part.hpp"
#include "solvers/linear/linear_solver.hpp"
#include "solvers/load_stepping.hpp"
#include "parallel/exchange.hpp"
#include "parallel/mpi/mpi_ranks.hpp"
#include "app/unknown_share.hpp"
#include "support/finite_difference.hpp"
#include "support/scenes.hpp"
#include "support/step_log.hpp"

namespace peristat {

/// MPI_COMM_WORLD's ranks, made in main() once MPI runs.
std::unique_ptr<Ranks> g_ranks;

namespace {

const Ranks& ranks() { return *g_ranks; }

/// A plate between mirror grips: rows on two ranks by strips, and owners for the layers.
struct Parted {
  Scene scene;
  Model whole;
  std::vector<int> owner;
  ModelPart part;
};

Parted parted_plate(int nx, int ny, BelosPartition kind = BelosPartition::strips) {
  test::PlateSpec spec;
  spec.nx = nx;
  spec.ny = ny;
  spec.boundary = test::mirror_tension_boundary(1e-3, spec);
  Parted p{test::scene_from_yaml(test::plate_yaml(spec)), {}, {}, {}};
  p.scene.solver.linear.belos.partition = kind;
  p.whole = discretise(p.scene);
  p.owner = owned_rows(p.scene, p.whole, ranks().rank(), ranks().size()).owner;  // every particle owned
  const int rank = ranks().rank();
  p.part = extract_part(p.whole, p.owner, rank, families_to_hold(p.whole, OwnedRows{rank, p.owner}, 1));
  return p;
}

TEST(PartExchange, EveryGhostGetsItsOwnersValue) {
  ASSERT_EQ(ranks().size(), 2) << "run under mpirun -n 2";
  const Parted p = parted_plate(40, 16);
  const ModelPart& part = p.part;
  const auto value = [](std::int64_t id) { return 1.0 + 0.5 * static_cast<double>(id); };
  std::vector<double> x(part.global_id.size(), std::numeric_limits<double>::quiet_NaN());
  for (Index l = 0; l < part.n_owned; ++l)
    x[static_cast<std::size_t>(l)] = value(part.global_id[static_cast<std::size_t>(l)]);
  PartExchange exchange(ranks(), part.global_id, part.owner, static_cast<std::size_t>(part.n_owned));
  EXPECT_GT(exchange.ghosts(), 0u);
  exchange.share(x.data());
  for (std::size_t l = 0; l < x.size(); ++l) ASSERT_EQ(x[l], value(part.global_id[l])) << "entry " << l;
}

TEST(PartLayout, EveryNodeHasOneGlobalNumber) {
  // The whole model's nodes (particles with an unknown) numbered 0 .. N-1 once each over the
  // ranks, a part's ghosts carrying their owners' numbers; with strips (each rank's nodes a
  // range of the whole model's) and RCB (not a range: the numbering must follow the owners).
  for (const BelosPartition kind : {BelosPartition::strips, BelosPartition::rcb}) {
    SCOPED_TRACE(std::string(to_string(kind)));
    const Parted p = parted_plate(16, 40, kind);  // tall: RCB cuts across y, strips (by index) across x
    const UnknownLayout layout = part_unknown_layout(p.part, ranks());
    const Constraints& wc = p.whole.constraints;
    std::int64_t nodes = 0;
    for (Index g = 0; g < p.whole.particles.size(); ++g)
      nodes += wc.free_index[2 * g] >= 0 || wc.free_index[2 * g + 1] >= 0;
    EXPECT_EQ(layout.global_nodes, nodes);
    // Rank by rank and, within a rank, in the whole model's order: the node numbering of a
    // layout whose owners every rank holds, recomputed here from the whole model.
    std::vector<std::int64_t> expected(static_cast<std::size_t>(p.whole.particles.size()), -1);
    std::int64_t next = 0;
    for (int r = 0; r < ranks().size(); ++r)
      for (Index g = 0; g < p.whole.particles.size(); ++g)
        if (p.owner[static_cast<std::size_t>(g)] == r &&
            (wc.free_index[2 * g] >= 0 || wc.free_index[2 * g + 1] >= 0))
          expected[static_cast<std::size_t>(g)] = next++;
    for (std::size_t l = 0; l < layout.global_node.size(); ++l)
      ASSERT_EQ(layout.global_node[l], expected[static_cast<std::size_t>(p.part.global_id[l])])
          << "particle " << l;
    double cx = 0.0, cy = 0.0;
    for (const Vec2& X : p.whole.particles.position) {
      cx += X.x();
      cy += X.y();
    }
    EXPECT_NEAR(layout.centre_x, cx / p.whole.particles.size(), 1e-15);
    EXPECT_NEAR(layout.centre_y, cy / p.whole.particles.size(), 1e-15);
  }
}

TEST(PartSolve, BelosOnThePartsSolvesTheWholeBondMatrix) {
  // Each rank assembles its rows of the bond matrix on its part and solves with Belos (CG,
  // MueLu) over the parts' unknowns; one process's CHOLMOD factor of the whole model's bond
  // matrix gives the reference. Krylov tolerance 1e-12: the answers within 1e-9 relative.
  const Parted p = parted_plate(60, 24);
  const ModelPart& part = p.part;
  const int rank = ranks().rank();
  ProblemOptions options = problem_options(p.scene);
  options.matrix_free = true;
  VectorXd x_ref;
  const VectorXd b = test::random_vector(p.whole.constraints.n_free, 1.0, 51u);
  {
    QuasiStaticProblem whole(p.whole, options);
    whole.set_load_factor(1.0);
    SparseMatrix none;
    VectorXd r;
    whole.evaluate(VectorXd::Zero(p.whole.constraints.n_free), r, &none);
    SparseMatrix P = whole.make_preconditioner();
    whole.assemble_preconditioner(P);
    Eigen::CholmodSupernodalLLT<SparseMatrix, Eigen::Lower> llt(P);
    ASSERT_EQ(llt.info(), Eigen::Success);
    x_ref = llt.solve(b);
  }
  ProblemOptions part_options = options;
  part_options.rows = OwnedRows{rank, part.owner};
  part_options.global_id = part.global_id;  // a part's own rows read no other rank's forces
  QuasiStaticProblem problem(part.model, part_options, ranks());
  problem.set_load_factor(1.0);
  const Index n = part.model.constraints.n_free;
  SparseMatrix none;
  VectorXd r;
  problem.evaluate(VectorXd::Zero(n), r, &none);
  SparseMatrix P = problem.make_preconditioner();
  problem.assemble_preconditioner(P);
  LinearOptions lin;
  lin.type = LinearSolverKind::belos;
  lin.belos.method = BelosMethod::cg;
  lin.belos.tangent = BelosTangent::assembled;
  lin.belos.rtol = 1e-12;
  register_linear_solvers();
  const std::unique_ptr<LinearSolver> solver =
      make_linear_solver(lin, {part_unknown_layout(part, ranks()), false, nullptr});
  solver->analyzePattern(P);
  solver->factorize(P);
  VectorXd bl(n), xl = VectorXd::Zero(n);
  for (Index f = 0; f < n; ++f) bl[f] = b[part.global_unknown[static_cast<std::size_t>(f)]];
  xl.tail(n - part.n_owned_unknowns).setConstant(std::numeric_limits<double>::quiet_NaN());
  solver->solve(bl, xl);
  ASSERT_EQ(solver->info(), Eigen::Success);
  EXPECT_GT(solver->stats().iterations, 0);
  // The solver writes the owned entries only; the ghosts come from their owners.
  for (Index f = 0; f < part.n_owned_unknowns; ++f)
    ASSERT_TRUE(std::isfinite(xl[f])) << "owned unknown " << f;
  PartExchange(ranks(), part.global_unknown, unknown_owners(part.model.constraints, part.owner),
               static_cast<std::size_t>(part.n_owned_unknowns))
      .share(xl.data());
  const double scale = x_ref.cwiseAbs().maxCoeff();
  double worst = 0.0;
  for (Index f = 0; f < n; ++f)  // owned and imported ghost entries alike
    worst =
        std::max(worst, std::abs(xl[f] - x_ref[part.global_unknown[static_cast<std::size_t>(f)]]) / scale);
  EXPECT_LT(worst, 1e-9) << "rank " << rank << ", " << solver->stats().iterations << " Krylov iterations";
  std::printf(
      "rank %d: %d unknowns (%d owned), %d Krylov iterations, largest difference %.2e of the largest entry\n",
      rank, n, part.n_owned_unknowns, solver->stats().iterations, worst);
}

/// The run of `scene` (its load steps, from zero) on this process's whole model with CHOLMOD:
/// the reference every rank computes alike.
VectorXd whole_run(Scene scene, std::vector<double>* residuals) {
  scene.solver.linear.type = LinearSolverKind::cholmod;
  const Model model = discretise(scene);
  QuasiStaticProblem problem(model, problem_options(scene));
  std::unique_ptr<LinearSolver> linear;
  const std::unique_ptr<StepSolver> solver = make_step_solver(scene, problem, linear);
  VectorXd x = VectorXd::Zero(problem.n_unknowns());
  test::StepLog log;
  const RunReport run = run_load_steps(problem, *solver, x, scene.loading, log);
  for (const StepReport& s : log.steps)
    residuals->insert(residuals->end(), s.residuals.begin(), s.residuals.end());
  EXPECT_TRUE(run.completed) << run.message;
  return x;
}

TEST(WholeView, RankZeroGathersTheWholeModelFromTheParts) {
  // What a run on the parts writes (app/whole_view.hpp): rank 0 gathers the particle table, a
  // field per particle and the state over the unknowns by global id; each must be the whole
  // model's exactly (a gather moves bits), and a whole state read back gives each part its own
  // and its ghosts' entries. RCB on a tall plate: the parts are not ranges of the whole's order.
  const Parted p = parted_plate(24, 40, BelosPartition::rcb);
  const int rank = ranks().rank();
  const WholeView view(p.part, ranks());
  ASSERT_EQ(view.particles(), static_cast<std::size_t>(p.whole.particles.size()));
  const ParticleTable table = view.particle_table(p.scene);
  const Particles& whole = p.whole.particles;
  if (rank == 0) {
    ASSERT_EQ(table.size(), static_cast<std::size_t>(whole.size()));
    for (Index i = 0; i < whole.size(); ++i) {
      const auto k = static_cast<std::size_t>(i);
      ASSERT_EQ(table.position[k], whole.position[k]) << "particle " << i;
      ASSERT_EQ(table.volume[k], whole.volume[k]) << "particle " << i;
      ASSERT_EQ(table.body[k], whole.body[k]) << "particle " << i;
      ASSERT_EQ(table.fictitious[k], static_cast<int>(whole.fictitious[k])) << "particle " << i;
    }
  } else {
    EXPECT_EQ(table.size(), 0u) << "only rank 0 receives";
  }
  // A field of two values per particle, known by global id.
  const Index n = p.part.model.particles.size();
  VectorXd mine(2 * n), gathered;
  for (Index l = 0; l < n; ++l) {
    const double id = static_cast<double>(p.part.global_id[static_cast<std::size_t>(l)]);
    mine[2 * l] = id;
    mine[2 * l + 1] = -0.5 * id;
  }
  view.particle_values(mine, 2, gathered);
  if (rank == 0) {
    ASSERT_EQ(gathered.size(), 2 * whole.size());
    for (Index i = 0; i < whole.size(); ++i) {
      ASSERT_EQ(gathered[2 * i], static_cast<double>(i));
      ASSERT_EQ(gathered[2 * i + 1], -0.5 * static_cast<double>(i));
    }
  }
  // The state: owned entries gathered; the ghosts' entries are not sent (NaN here, so a gather
  // that read them would show).
  VectorXd x(p.part.model.constraints.n_free);
  x.setConstant(std::numeric_limits<double>::quiet_NaN());
  for (Index f = 0; f < p.part.n_owned_unknowns; ++f)
    x[f] = 1.0 + static_cast<double>(p.part.global_unknown[static_cast<std::size_t>(f)]);
  const std::vector<double> state = view.unknowns(x);
  std::vector<double> reference(static_cast<std::size_t>(p.whole.constraints.n_free));
  for (std::size_t f = 0; f < reference.size(); ++f) reference[f] = 1.0 + static_cast<double>(f);
  if (rank == 0) {
    EXPECT_EQ(state, reference);
  }
  const VectorXd back = view.unknowns_from(reference);
  ASSERT_EQ(back.size(), x.size());
  for (Index f = 0; f < back.size(); ++f)
    ASSERT_EQ(back[f], 1.0 + static_cast<double>(p.part.global_unknown[static_cast<std::size_t>(f)]))
        << "unknown " << f;
}

TEST(PartNewton, NewtonOnThePartsReachesTheWholeModelsAnswer) {
  // The load steps of a tension plate between mirror grips (finite kinematics, a 1 % stretch in
  // two steps), run by each rank on its part of the model (strips, and RCB): Newton with belos (the
  // matrix-free tangent, MueLu) over the parts' unknowns, norms summed over the ranks, each evaluation
  // importing its ghosts. Every state check of a run applies (finite state, the residual
  // recomputed). The owned and ghost entries must be the whole model's answer (CHOLMOD, one
  // process) within 1e-8 of its largest entry (both Newton runs stop at rtol 1e-10), and
  // every rank must take the same Newton iterations (the same decisions).
  const int rank = ranks().rank();
  test::PlateSpec spec;  // tall: RCB's parts (across y) are not strips of the particle order (across x)
  spec.nx = 24;
  spec.ny = 60;
  spec.steps = 2;
  spec.boundary = test::mirror_tension_boundary(1e-2, spec);
  spec.solver = "  type: newton\n  linear: belos\n  newton: {rtol: 1.0e-10}\n";
  const Scene scene = test::scene_from_yaml(test::plate_yaml(spec));
  std::vector<double> whole_residuals;
  const VectorXd x_ref = whole_run(scene, &whole_residuals);

  for (const BelosPartition kind : {BelosPartition::strips, BelosPartition::rcb}) {
    SCOPED_TRACE(std::string(to_string(kind)));
    Scene parted = scene;
    parted.solver.linear.belos.partition = kind;
    const ModelPart part = part_model(parted, rank, ranks().size());
    const ProblemOptions options = part_problem_options(scene, scene_plan(scene, ranks().size()), part, rank);
    ASSERT_TRUE(options.matrix_free);
    QuasiStaticProblem problem(part.model, options, ranks());
    std::unique_ptr<LinearSolver> linear;
    const std::unique_ptr<StepSolver> solver = make_step_solver(scene, problem, linear, &part);
    VectorXd x = VectorXd::Zero(problem.n_unknowns());
    std::vector<double> residuals;
    test::StepLog log;
    const RunReport run = run_load_steps(problem, *solver, x, scene.loading, log);
    for (const StepReport& s : log.steps)
      residuals.insert(residuals.end(), s.residuals.begin(), s.residuals.end());
    ASSERT_TRUE(run.completed) << run.message;
    problem.import_ghosts(x);  // the run keeps the owned entries right; the ghosts from their owners
    const double scale = x_ref.cwiseAbs().maxCoeff();
    double worst = 0.0;
    for (Index f = 0; f < x.size(); ++f)
      worst =
          std::max(worst, std::abs(x[f] - x_ref[part.global_unknown[static_cast<std::size_t>(f)]]) / scale);
    EXPECT_LT(worst, 1e-8) << "rank " << rank;
    // The same decisions on every rank: the residual histories (relative residuals, collective) alike.
    const std::vector<double> all = ranks().all_gather(residuals);
    ASSERT_EQ(all.size(), residuals.size() * static_cast<std::size_t>(ranks().size()));
    for (std::size_t k = 0; k < residuals.size(); ++k)
      EXPECT_EQ(all[k], all[k + residuals.size()]) << "residual " << k;
    std::printf("%s, rank %d: %d unknowns (%d owned); Newton residuals", std::string(to_string(kind)).c_str(),
                rank, problem.n_unknowns(), part.n_owned_unknowns);
    for (const double r : residuals) std::printf(" %.2e", r);
    std::printf("; whole (CHOLMOD)");
    for (const double r : whole_residuals) std::printf(" %.2e", r);
    std::printf("; largest difference %.2e of the largest entry\n", worst);
  }
}

}  // namespace
}  // namespace peristat

int main(int argc, char** argv) {
  const peristat::parallel::Session mpi;
  peristat::g_ranks = peristat::parallel::process_ranks();
  testing::InitGoogleTest(&argc, argv);
  const int failed = RUN_ALL_TESTS();
  peristat::g_ranks.reset();
  return failed;
}
