// peristat_bench: performance measurements (not tests). See docs/performance.md.
//   peristat_bench tension N [--set KEY=VALUE]...    square N x N plate in tension, one
//       load step: model build, assembly, factorisation, solve times, iterations, nonzeros,
//       peak memory; one CSV line on stdout.
//   peristat_bench factor N MATRIX ORDERING          CHOLMOD analyse + factorise of the
//       tangent (MATRIX = tangent) or its bond part (MATRIX = bond) with ORDERING = default |
//       amd | metis | nesdis.
//   peristat_bench action SCENE [REPS] [--set KEY=VALUE]...   the matrix-free tangent action
//       (apply_tangent) of SCENE at load factor 1 and zero displacement: time per action
//       (best and median of REPS, default 200), bonds, and bytes of bond data read per second.
//   peristat_bench residual SCENE [REPS] [--set KEY=VALUE]...   one evaluation of the residual
//       (evaluate without a tangent: the families' force laws and the force gather) of SCENE at
//       load factor 1 and the displacement of one Newton step from zero: best and median of
//       REPS (default 50).
//   peristat_bench cycle SCENE [REPS] [--set KEY=VALUE]...   one application of the bond_amg
//       V-cycle (matrix_free's default preconditioner) of SCENE's bond matrix at load factor 1
//       and zero displacement, applied by this program's threads (ThreadedCycle, the default)
//       and by MueLu's own apply: median time of REPS (default 20) each, the finest matrix's
//       rows and nonzeros, and the set-up time.
//   peristat_bench stream [MB]                      the memory bandwidth a streaming kernel
//       reaches on this machine (STREAM's copy c = a and triad a = b + 3 c over arrays of MB
//       megabytes each, default 256, best of 10 passes, with the threads OpenMP gives): the
//       bound the hot paths' GB/s above are measured against (docs/performance.md).
//   peristat_bench partition SCENE P [--set KEY=VALUE]...   the rows of P ranks by strips and
//       by RCB (solver.belos.partition): per partition, the largest and mean number of owned
//       particles and of ghost particles (the other ranks' particles that a rank's rows of the
//       tangent couple to: the halo a Krylov iteration exchanges), one line each.
//   peristat_bench parts SCENE P [--set KEY=VALUE]...   each rank's part of the model
//       (extract_part: docs/guide/distributed.md, "The partitioned model") on P ranks by strips and by RCB,
//       with Newton's matrix-free problem on it: per partition, the largest and mean bytes of a part's model
//       and problem state (ModelSize::memory_bytes) against the whole model's, and its particles (owned, and
//       the ring and the particles without a row it adds).
//   mpirun -n P peristat_bench part-newton SCENE [--set KEY=VALUE]...   the scene's load steps
//       run by Newton with belos on each rank's part of the model (the partitioned model,
//       stages 1-2, below the command line): per rank, the particles and unknowns it holds,
//       the resident memory once the part is built and at the end, the peak, and the times.
//   peristat_bench build SCENE P [--set KEY=VALUE]...   the growth of the peak resident memory
//       and the time while one process builds rank 0's part of P from the census (P = 1: the
//       whole model, discretise()), one line; run once per P (the peak only grows).
#include <algorithm>
#include <cstdio>
#include <cstring>
#include <memory>
#include <string>
#include <sys/resource.h>
#include <vector>

#include <Eigen/CholmodSupport>
#include <omp.h>

#include "app/linear_solvers.hpp"
#include "app/model_size.hpp"
#include "app/setup.hpp"
#include "assembly/quasi_static.hpp"
#include "core/clock.hpp"
#include "discretisation/model_part.hpp"
#include "parallel/mpi/mpi_ranks.hpp"
#include "solvers/linear/linear_solver.hpp"
#include "solvers/load_stepping.hpp"
#include "solvers/newton.hpp"
#include "solvers/trilinos/belos_solver.hpp"
#include "support/step_log.hpp"

using namespace peristat;

namespace {

double peak_mb() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return u.ru_maxrss / 1024.0;
}

std::string plate_scene(int n) {
  char buf[1024];
  const double dx = 0.1 / n;
  std::snprintf(buf, sizeof buf,
                "name: bench_plate\n"
                "materials: {al: {E: 70.0e9, nu: 0.33, thickness: 1.0e-3}}\n"
                "discretization: {spacing: %.17g}\n"
                "bodies: {plate: {material: al, rectangle: {min: [0, 0], max: [0.1, 0.1]}}}\n"
                "boundary:\n"
                "  - {body: plate, edge: left, ux: 0}\n"
                "  - {body: plate, edge: right, ux: 1.0e-4}\n"
                "  - {body: plate, region: {min: [0, %.17g], max: [%.17g, %.17g]}, uy: 0}\n",
                dx, 0.05 - dx, dx, 0.05 + dx);
  return buf;
}

std::vector<Override> overrides_from(int argc, char** argv, int first) {
  std::vector<Override> o;
  for (int i = first; i + 1 < argc; ++i)
    if (std::strcmp(argv[i], "--set") == 0) o.push_back(parse_override(argv[++i]));
  return o;
}

int tension(int n, const std::vector<Override>& overrides) {
  const double t0 = wall_seconds();
  const Scene scene = parse_scene_text(plate_scene(n), "bench_plate.yaml", overrides);
  const Model model = discretise(scene);
  const double t_discretise = wall_seconds() - t0;
  QuasiStaticProblem problem(model, problem_options(scene));
  const double t_model = wall_seconds() - t0;
  const long long nonzeros = problem.pattern().nonzeros;
  std::fprintf(stderr, "discretise %.2f s, problem set-up (pattern) %.2f s\n", t_discretise,
               t_model - t_discretise);
  auto linear = make_problem_linear_solver(scene, problem, scene.solver.linear);
  NewtonSolver newton(problem, *linear, scene.solver.newton);
  VectorXd x = VectorXd::Zero(problem.n_unknowns());
  problem.set_load_factor(0.0);
  StepReport last;
  int steps = 0, newton_its = 0, lin_its = 0, facts = 0;
  double evaluate = 0, factorize = 0, solve = 0;
  test::StepLog log;
  const double t1 = wall_seconds();
  const RunReport run = run_load_steps(problem, newton, x, scene.loading, log);
  const double t_solve = wall_seconds() - t1;
  for (const StepReport& s : log.steps) {
    ++steps;
    newton_its += s.newton_iterations;
    lin_its += s.linear_iterations;
    facts += s.factorizations;
    evaluate += s.seconds_evaluate;
    factorize += s.seconds_factorize;
    solve += s.seconds_solve;
    last = s;
  }
  const double per_it = newton_its > 0 ? t_solve / newton_its : 0.0;
  std::printf(
      "n,particles,unknowns,nonzeros,linear,threads,model_s,solve_s,total_s,newton_its,krylov_its,"
      "factorizations,evaluate_s,factorize_s,linsolve_s,assembly_share,final_residual,peak_mb,completed\n");
  std::printf("%d,%d,%d,%lld,%s,%d,%.3f,%.3f,%.3f,%d,%d,%d,%.3f,%.3f,%.3f,%.3f,%.2e,%.0f,%d\n", n,
              model.particles.size(), problem.n_unknowns(), nonzeros, linear->name().c_str(),
              omp_get_max_threads(), t_model, t_solve, t_model + t_solve, newton_its, lin_its, facts,
              evaluate, factorize, solve, per_it > 0 ? (evaluate / newton_its) / per_it : 0.0,
              last.final_residual, peak_mb(), run.completed ? 1 : 0);
  return run.completed ? 0 : 3;
}

int factor(int n, const std::string& which, const std::string& ordering) {
  const Scene scene = parse_scene_text(plate_scene(n), "bench_plate.yaml");
  const Model model = discretise(scene);
  QuasiStaticProblem problem(model, problem_options(scene));
  problem.set_load_factor(1.0);
  VectorXd x = VectorXd::Zero(problem.n_unknowns()), r;
  SparseMatrix K = problem.make_tangent();
  problem.evaluate(x, r, &K);
  SparseMatrix A = K;
  if (which == "bond") {
    A = problem.make_preconditioner();
    problem.assemble_preconditioner(A);
  }
  Eigen::CholmodSupernodalLLT<SparseMatrix, Eigen::Lower> llt;
  cholmod_common& c = llt.cholmod();
  if (ordering != "default") {
    c.nmethods = 1;
    c.method[0].ordering = ordering == "amd"     ? CHOLMOD_AMD
                           : ordering == "metis" ? CHOLMOD_METIS
                                                 : CHOLMOD_NESDIS;
    c.postorder = 1;
  }
  const double t0 = wall_seconds();
  llt.analyzePattern(A);
  const double t1 = wall_seconds();
  llt.factorize(A);
  const double t2 = wall_seconds();
  VectorXd sol = llt.solve(-r);
  const double t3 = wall_seconds();
  std::printf(
      "n=%d matrix=%s ordering=%s nnz=%lld analyse=%.2fs factorise=%.2fs solve=%.3fs factor_nnz=%.0f "
      "flops=%.3g peak=%.0fMB info=%d\n",
      n, which.c_str(), ordering.c_str(), (long long)A.nonZeros(), t1 - t0, t2 - t1, t3 - t2, c.lnz, c.fl,
      peak_mb(), (int)llt.info());
  return 0;
}

int stream(long megabytes) {
  const auto n = static_cast<std::size_t>(std::max(1L, megabytes) * 1000000L / sizeof(double));
  std::vector<double> a(n), b(n), c(n);
  const auto size = static_cast<std::ptrdiff_t>(n);
#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t i = 0; i < size; ++i) {  // first touch by the thread that streams it
    a[i] = 1.0;
    b[i] = 2.0;
    c[i] = 0.5;
  }
  double copy = 1e300, triad = 1e300;
  for (int pass = 0; pass < 10; ++pass) {
    const double t0 = wall_seconds();
#pragma omp parallel for schedule(static)
    for (std::ptrdiff_t i = 0; i < size; ++i) c[i] = a[i];
    const double t1 = wall_seconds();
#pragma omp parallel for schedule(static)
    for (std::ptrdiff_t i = 0; i < size; ++i) a[i] = b[i] + 3.0 * c[i];
    const double t2 = wall_seconds();
    copy = std::min(copy, t1 - t0);
    triad = std::min(triad, t2 - t1);
  }
  // STREAM's counting: copy moves 2 arrays, triad 3 (write-allocate traffic not counted).
  const double bytes = static_cast<double>(n * sizeof(double));
  std::printf("threads=%d array=%.0fMB copy=%.1fGB/s triad=%.1fGB/s check=%.6g\n", omp_get_max_threads(),
              bytes / 1e6, 2.0 * bytes / copy * 1e-9, 3.0 * bytes / triad * 1e-9, a[n / 2]);
  return 0;
}

/// A scene's matrix-free problem, evaluated with its tangent at load factor 1 and zero
/// displacement: what the action and the V-cycle are timed on.
struct Evaluated {
  Scene scene;
  Model model;
  std::unique_ptr<QuasiStaticProblem> problem;
};
std::unique_ptr<Evaluated> evaluated(const std::string& path, const std::vector<Override>& overrides) {
  auto e = std::make_unique<Evaluated>();
  e->scene = parse_scene(path, overrides);
  e->model = discretise(e->scene);
  ProblemOptions options = problem_options(e->scene);
  options.matrix_free = true;
  options.float_factors = e->scene.solver.action_factors == ActionFactors::single_precision;
  options.float_copy = e->scene.solver.action_factors == ActionFactors::mixed;
  e->problem = std::make_unique<QuasiStaticProblem>(e->model, options);
  e->problem->set_load_factor(1.0);
  VectorXd x = VectorXd::Zero(e->problem->n_unknowns()), r;
  SparseMatrix placeholder = e->problem->make_tangent();
  e->problem->evaluate(x, r, &placeholder);
  return e;
}

int action(const std::string& path, int reps, const std::vector<Override>& overrides) {
  const auto e = evaluated(path, overrides);
  const Scene& scene = e->scene;
  const Model& model = e->model;
  QuasiStaticProblem& problem = *e->problem;
  VectorXd y;
  VectorXd v = VectorXd::Ones(problem.n_unknowns());
  problem.apply_tangent(v, y);  // first touch
  std::vector<double> t(static_cast<std::size_t>(reps));
  double checksum = 0.0;
  for (double& ti : t) {
    const double t0 = wall_seconds();
    problem.apply_tangent(v, y);
    ti = wall_seconds() - t0;
    checksum += y.norm();
    v[0] += 1e-3;  // not a constant input
  }
  std::sort(t.begin(), t.end());
  const double bonds = model.bonds.n_bonds();
  // Per bond, the data the single pass streams: the neighbour index, s_b and the pair stiffness,
  // in double or float (--set solver.krylov.factors=float, or mixed: the float copy); v, the
  // dilatation rates and y are per particle and stay in cache. The pair stiffness is used for
  // half the bonds (j > i), but those lie among the others in the family's order: every cache
  // line of it is fetched.
  const bool single = scene.solver.action_factors == ActionFactors::single_precision ||
                      scene.solver.action_factors == ActionFactors::mixed;
  const double bytes =
      bonds * static_cast<double>(sizeof(Index) +
                                  (single ? 2 * sizeof(Float2) : sizeof(Vec2) + sizeof(BondStiffness)));
  std::printf("scene=%s particles=%d bonds=%.0f unknowns=%d threads=%d best=%.3fms median=%.3fms "
              "bond data read at %.1f GB/s checksum=%.6e\n",
              scene.name.c_str(), model.particles.size(), bonds, problem.n_unknowns(), omp_get_max_threads(),
              1e3 * t.front(), 1e3 * t[t.size() / 2], bytes / t[t.size() / 2] * 1e-9, checksum);
  return 0;
}

int residual(const std::string& path, int reps, const std::vector<Override>& overrides) {
  const auto e = evaluated(path, overrides);
  QuasiStaticProblem& problem = *e->problem;
  // A state with every bond stretched: the residual at zero displacement (the load's) as a
  // displacement, scaled to strains of about 1e-3.
  VectorXd r;
  problem.evaluate(VectorXd::Zero(problem.n_unknowns()), r, nullptr);
  const double scale = r.cwiseAbs().maxCoeff();
  const VectorXd x = scale > 0.0 ? VectorXd(r * (1e-3 * e->model.spacing / scale)) : r;
  problem.evaluate(x, r, nullptr);  // first touch
  std::vector<double> t(static_cast<std::size_t>(reps));
  double checksum = 0.0;
  for (double& ti : t) {
    const double t0 = wall_seconds();
    problem.evaluate(x, r, nullptr);
    ti = wall_seconds() - t0;
    checksum += r.norm();
  }
  std::sort(t.begin(), t.end());
  std::printf("scene=%s particles=%d bonds=%.0f threads=%d best=%.3fms median=%.3fms checksum=%.6e\n",
              e->scene.name.c_str(), e->model.particles.size(), static_cast<double>(e->model.bonds.n_bonds()),
              omp_get_max_threads(), 1e3 * t.front(), 1e3 * t[t.size() / 2], checksum);
  return 0;
}

// One application of the V-cycle of SCENE's bond matrix, by each applier in turn.
int cycle(const std::string& path, int reps, const std::vector<Override>& overrides) {
  const auto e = evaluated(path, overrides);
  const Scene& scene = e->scene;
  const Model& model = e->model;
  QuasiStaticProblem& problem = *e->problem;
  const VectorXd b = VectorXd::Ones(problem.n_unknowns());
  const std::pair<CycleApply, const char*> appliers[] = {{CycleApply::threads, "threads"},
                                                         {CycleApply::muelu, "muelu"}};
  for (const auto& [apply, label] : appliers) {
    SparseMatrix P = problem.make_preconditioner();
    problem.assemble_preconditioner(P);
    const double rows = P.rows(), nonzeros = P.nonZeros();
    std::unique_ptr<Preconditioner> m =
        make_muelu_cycle({unknown_layout(model, problem.n_unknowns()), false, nullptr}, apply);
    m->analyzePattern(P);
    const double t0 = wall_seconds();
    m->factorize(P);
    const double setup = wall_seconds() - t0;
    P = SparseMatrix();  // as a run frees it
    VectorXd y;
    m->solve(b, y);  // first touch
    std::vector<double> t(static_cast<std::size_t>(reps));
    for (double& ti : t) {
      const double t1 = wall_seconds();
      m->solve(b, y);
      ti = wall_seconds() - t1;
    }
    std::sort(t.begin(), t.end());
    // The matrix data a cycle reads (threads only: the hierarchy's levels as the threads sweep them).
    const double bytes = m->matrix_bytes_per_solve();
    std::printf(
        "scene=%s apply=%s name=%s threads=%d rows=%.0f nonzeros=%.0f setup=%.2fs best=%.2fms "
        "median=%.2fms matrix_MB_per_cycle=%.1f matrix_data_read_GB/s=%.1f norm=%.6e\n",
        scene.name.c_str(), label, m->name().c_str(), omp_get_max_threads(), rows, nonzeros, setup,
        1e3 * t.front(), 1e3 * t[t.size() / 2], bytes / 1e6, bytes / t[t.size() / 2] * 1e-9, y.norm());
  }
  return 0;
}

int partition(const std::string& path, int ranks, const std::vector<Override>& overrides) {
  Scene scene = parse_scene(path, overrides);
  const Model model = discretise(scene);
  const Constraints& cons = model.constraints;
  const auto has_unknown = [&](Index p) { return cons.free_index[2 * p] >= 0 || cons.free_index[2 * p + 1] >= 0; };
  for (const BelosPartition kind : {BelosPartition::strips, BelosPartition::rcb}) {
    scene.solver.linear.belos.partition = kind;
    const double t0 = wall_seconds();
    const std::vector<int> owner = owned_rows(scene, model, 0, ranks).owner;
    const double t_partition = wall_seconds() - t0;
    long long owned_max = 0, owned_sum = 0, ghosts_max = 0, ghosts_sum = 0;
    for (int rank = 0; rank < ranks; ++rank) {
      const OwnedRows rows{rank, owner};
      const TangentPattern pat = build_pattern(model, PatternReach::two_horizons, 0.0, nullptr, rows);
      long long owned = 0, ghosts = 0;
      for (Index p = 0; p < model.particles.size(); ++p) {
        if (!has_unknown(p)) continue;
        if (rows.contains(p))
          ++owned;
        else if (pat.col_start[p] < pat.col_start[p + 1])
          ++ghosts;  // a column of another rank's particle that holds one of this rank's rows
      }
      owned_max = std::max(owned_max, owned);
      owned_sum += owned;
      ghosts_max = std::max(ghosts_max, ghosts);
      ghosts_sum += ghosts;
    }
    std::printf("scene=%s partition=%s ranks=%d particles_with_unknowns=%lld owned_max=%lld owned_mean=%.0f "
                "ghosts_max=%lld ghosts_mean=%.0f halo_bytes_per_exchange=%lld partition_seconds=%.3f\n",
                scene.name.c_str(), std::string(to_string(kind)).c_str(), ranks, owned_sum, owned_max,
                double(owned_sum) / ranks, ghosts_max, double(ghosts_sum) / ranks, 16 * ghosts_sum, t_partition);
  }
  return 0;
}

int parts(const std::string& path, int ranks, const std::vector<Override>& overrides) {
  Scene scene = parse_scene(path, overrides);
  const Model whole = discretise(scene);
  ProblemOptions options = problem_options(scene);
  options.matrix_free = true;
  double whole_bytes = 0.0;
  {
    const QuasiStaticProblem problem(whole, options);
    whole_bytes = measure(whole, problem).memory_bytes;
  }
  std::printf("scene=%s particles=%d bonds=%d whole_bytes_per_particle=%.1f whole_MB=%.1f\n",
              scene.name.c_str(), whole.particles.size(), whole.bonds.n_bonds(),
              whole_bytes / whole.particles.size(), whole_bytes / 1e6);
  for (const BelosPartition kind : {BelosPartition::strips, BelosPartition::rcb}) {
    scene.solver.linear.belos.partition = kind;
    const std::vector<int> owner = owned_rows(scene, whole, 0, ranks).owner;
    double bytes_max = 0.0, bytes_sum = 0.0, extract_seconds = 0.0;
    long long kept_max = 0, kept_sum = 0, owned_max = 0, bonds_max = 0;
    for (int rank = 0; rank < ranks; ++rank) {
      const OwnedRows rows{rank, owner};
      const double t0 = wall_seconds();
      const ModelPart part = extract_part(whole, owner, rank, families_to_hold(whole, rows, 1));
      extract_seconds = std::max(extract_seconds, wall_seconds() - t0);
      ProblemOptions part_options = options;
      part_options.rows = OwnedRows{rank, part.owner};  // one rank's part, measured alone
      part_options.global_id = part.global_id;
      const QuasiStaticProblem problem(part.model, part_options);
      const double bytes = measure(part.model, problem).memory_bytes +
                           static_cast<double>(part.memory_bytes() - part.model.memory_bytes());
      bytes_max = std::max(bytes_max, bytes);
      bytes_sum += bytes;
      kept_max = std::max<long long>(kept_max, part.model.particles.size());
      kept_sum += part.model.particles.size();
      owned_max = std::max<long long>(owned_max, part.n_owned);
      bonds_max = std::max<long long>(bonds_max, part.model.bonds.n_bonds());
    }
    std::printf(
        "partition=%s ranks=%d part_MB_max=%.1f part_MB_mean=%.1f whole_over_P_MB=%.1f "
        "particles_max=%lld particles_mean=%.0f owned_max=%lld bonds_max=%lld extract_seconds_max=%.2f\n",
        std::string(to_string(kind)).c_str(), ranks, bytes_max / 1e6, bytes_sum / ranks / 1e6,
        whole_bytes / ranks / 1e6, kept_max, double(kept_sum) / ranks, owned_max, bonds_max, extract_seconds);
  }
  return 0;
}

/// Resident memory now [MB] (/proc/self/statm).
double resident_mb() {
  long pages = 0, resident = 0;
  if (FILE* f = std::fopen("/proc/self/statm", "r")) {
    if (std::fscanf(f, "%ld %ld", &pages, &resident) != 2) resident = 0;
    std::fclose(f);
  }
  return static_cast<double>(resident) * 4096.0 / 1e6;
}

int build(const std::string& path, int ranks, const std::vector<Override>& overrides) {
  const Scene scene = parse_scene(path, overrides);
  const double peak_before = peak_mb(), t0 = wall_seconds();
  const Model model = ranks <= 1 ? discretise(scene) : part_model(scene, 0, ranks).model;
  const double seconds = wall_seconds() - t0, growth = peak_mb() - peak_before;
  std::printf("build ranks=%d particles=%d bonds=%d model_MB=%.1f peak_growth_MB=%.1f seconds=%.2f\n", ranks,
              model.particles.size(), model.bonds.n_bonds(), model.memory_bytes() / 1e6, growth, seconds);
  return 0;
}

int part_newton(const std::string& path, const std::vector<Override>& overrides) {
  const parallel::Session mpi;
  const std::unique_ptr<Ranks> on = parallel::process_ranks();
  const int rank = on->rank(), ranks = on->size();
  Scene scene = parse_scene(path, overrides);
  scene.solver.type = SolverKind::newton;
  scene.solver.linear.type = LinearSolverKind::belos;
  const double t0 = wall_seconds();
  const ModelPart part = part_model(scene, rank, ranks);
  const double t_part = wall_seconds() - t0, rss_part = resident_mb();
  QuasiStaticProblem problem(part.model, part_problem_options(scene, scene_plan(scene, ranks), part, rank), *on);
  std::unique_ptr<LinearSolver> linear;
  const std::unique_ptr<StepSolver> solver = make_step_solver(scene, problem, linear, &part);
  const double t_problem = wall_seconds() - t0 - t_part;
  VectorXd x = VectorXd::Zero(problem.n_unknowns());
  int newton = 0, krylov = 0;
  double residual = 0.0;
  test::StepLog log;
  const double t1 = wall_seconds();
  const RunReport run = run_load_steps(problem, *solver, x, scene.loading, log);
  const double t_run = wall_seconds() - t1;
  for (const StepReport& s : log.steps) {
    newton += s.newton_iterations;
    krylov += s.linear_iterations;
    residual = s.final_residual;
  }
  const std::vector<double> mine = {static_cast<double>(part.model.particles.size()),
                                    static_cast<double>(part.n_owned),
                                    static_cast<double>(problem.n_unknowns()),
                                    static_cast<double>(part.n_owned_unknowns),
                                    rss_part,
                                    resident_mb(),
                                    peak_mb() * 1.024 * 1.024,
                                    t_part,
                                    t_problem,
                                    t_run};
  const std::vector<double> all = on->all_gather(mine);
  if (rank == 0) {
    std::printf(
        "scene=%s ranks=%d particles_whole=%lld completed=%d newton=%d krylov=%d final_residual=%.3e %s\n",
        scene.name.c_str(), ranks, static_cast<long long>(part.n_particles_whole), run.completed ? 1 : 0,
        newton, krylov, residual, run.completed ? "" : run.message.c_str());
    for (int r = 0; r < ranks; ++r) {
      const double* v = all.data() + static_cast<std::size_t>(r) * mine.size();
      std::printf(
          "rank=%d particles=%.0f owned=%.0f unknowns=%.0f owned_unknowns=%.0f rss_after_part_MB=%.0f "
          "rss_end_MB=%.0f peak_MB=%.0f part_s=%.1f problem_s=%.1f run_s=%.1f\n",
          r, v[0], v[1], v[2], v[3], v[4], v[5], v[6], v[7], v[8], v[9]);
    }
  }
  return run.completed ? 0 : 3;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc >= 3 && std::strcmp(argv[1], "tension") == 0)
    return tension(std::atoi(argv[2]), overrides_from(argc, argv, 3));
  if (argc >= 5 && std::strcmp(argv[1], "factor") == 0) return factor(std::atoi(argv[2]), argv[3], argv[4]);
  if (argc >= 2 && std::strcmp(argv[1], "stream") == 0) return stream(argc >= 3 ? std::atol(argv[2]) : 256);
  const auto reps = [&](int fallback) {
    return argc >= 4 && argv[3][0] != '-' ? std::atoi(argv[3]) : fallback;
  };
  if (argc >= 3 && std::strcmp(argv[1], "action") == 0)
    return action(argv[2], reps(200), overrides_from(argc, argv, 3));
  if (argc >= 3 && std::strcmp(argv[1], "residual") == 0)
    return residual(argv[2], reps(50), overrides_from(argc, argv, 3));
  if (argc >= 3 && std::strcmp(argv[1], "cycle") == 0)
    return cycle(argv[2], reps(20), overrides_from(argc, argv, 3));
  if (argc >= 4 && std::strcmp(argv[1], "partition") == 0)
    return partition(argv[2], std::atoi(argv[3]), overrides_from(argc, argv, 4));
  if (argc >= 3 && std::strcmp(argv[1], "part-newton") == 0)
    return part_newton(argv[2], overrides_from(argc, argv, 3));
  if (argc >= 4 && std::strcmp(argv[1], "build") == 0)
    return build(argv[2], std::atoi(argv[3]), overrides_from(argc, argv, 4));
  if (argc >= 4 && std::strcmp(argv[1], "parts") == 0)
    return parts(argv[2], std::atoi(argv[3]), overrides_from(argc, argv, 4));
  std::fprintf(stderr,
               "usage: peristat_bench tension N [--set KEY=VALUE]...\n"
               "       peristat_bench factor N tangent|bond default|amd|metis|nesdis\n"
               "       peristat_bench action SCENE [REPS] [--set KEY=VALUE]...\n"
               "       peristat_bench residual SCENE [REPS] [--set KEY=VALUE]...\n"
               "       peristat_bench cycle SCENE [REPS] [--set KEY=VALUE]...\n"
               "       peristat_bench stream [MB]\n"
               "       peristat_bench partition SCENE P [--set KEY=VALUE]...\n"
               "       peristat_bench parts SCENE P [--set KEY=VALUE]...\n"
               "       mpirun -n P peristat_bench part-newton SCENE [--set KEY=VALUE]...\n");
  return 2;
}
