#include "app/commands.hpp"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <unistd.h>

#include <omp.h>

#include "app/interrupt.hpp"
#include "app/model_size.hpp"
#include "app/preflight.hpp"
#include "app/progress.hpp"
#include "app/setup.hpp"
#include "app/step_recorder.hpp"
#include "app/whole_view.hpp"
#include "assembly/quasi_static.hpp"
#include "core/clock.hpp"
#include "core/error.hpp"
#include "core/huge_pages.hpp"
#include "discretisation/model.hpp"
#include "io/checkpoint.hpp"
#include "io/results.hpp"
#include "parallel/mpi/mpi_ranks.hpp"
#include "solvers/adr.hpp"
#include "solvers/linear/linear_solver.hpp"
#include "solvers/load_stepping.hpp"
#include "solvers/newton.hpp"

namespace peristat {

namespace {

/// A plain process whose run is estimated at kHugePageMallocBytes or more starts again with
/// glibc's malloc on huge pages (core/huge_pages.hpp). Not under mpirun: MPI's launcher
/// started the process, and the user passes the tunable with `mpirun -x GLIBC_TUNABLES=...`.
void start_large_runs_on_huge_pages(const SizeEstimate& e) {
  if (parallel::launched_by_mpirun() || parallel::started()) return;
  start_malloc_on_huge_pages(e.memory_bytes + e.factor_bytes);
}

}  // namespace

namespace {

std::vector<Override> parse_overrides(const std::vector<std::string>& assignments) {
  std::vector<Override> out;
  for (const std::string& a : assignments) out.push_back(parse_override(a));
  return out;
}

/// Runs the load steps; turns the outcome into an exit code, the final status and a message.
int finish_run(StepRecorder& recorder, const std::function<RunReport()>& run, bool verbose, double t_start) {
  install_interrupt_handlers();
  RunReport report;
  try {
    report = run();
  } catch (const Interrupted& stop) {
    const std::string message = "interrupted by signal " + std::to_string(stop.signal);
    recorder.finish("interrupted", message);
    std::fprintf(stderr, "peristat: %s; converged steps kept in %s\n", message.c_str(),
                 recorder.h5_path().c_str());
    return 128 + stop.signal;
  }
  if (!report.completed) {
    recorder.finish("no_convergence", report.message);
    std::fprintf(stderr, "peristat: %s; %d converged step(s) kept in %s\n", report.message.c_str(),
                 report.steps_done, recorder.h5_path().c_str());
    return exit_no_convergence;
  }
  recorder.finish("completed", "completed");
  if (verbose)
    std::printf("peristat: done in %.2f s; results in %s\n", wall_seconds() - t_start,
                recorder.h5_path().c_str());
  return exit_success;
}

/// The options a checkpoint was written with, as texts (compared on --resume).
std::string joined(const std::vector<std::string>& items) {
  std::string out;
  for (const std::string& item : items) out += (out.empty() ? "" : " ") + item;
  return out;
}

/// Refuses (InputError) a resume whose scene or options differ from the checkpoint's, saying which.
void check_same_run(const StateArchive& checkpoint, const std::string& path, const Scene& scene,
                    const RunArguments& args) {
  const auto text = [&](const std::string& key) {
    const auto it = checkpoint.texts.find(key);
    return it == checkpoint.texts.end() ? std::string() : it->second;
  };
  if (text("overrides") != joined(args.overrides))
    throw InputError(path + ": the run was started with --set options [" + text("overrides") +
                     "], the resume has [" + joined(args.overrides) + "]; give the same options");
  if (text("solver") != args.solver)
    throw InputError(path + ": the run was started with --solver '" + text("solver") + "', the resume has '" +
                     args.solver + "'");
  const std::string before = text("scene");
  if (before == scene.text) return;
  // The first line that differs.
  std::size_t line = 1, a = 0, b = 0;
  for (;;) {
    const std::size_t ea = before.find('\n', a), eb = scene.text.find('\n', b);
    const std::string la = before.substr(a, ea - a), lb = scene.text.substr(b, eb - b);
    if (la != lb || ea == std::string::npos || eb == std::string::npos)
      throw InputError(path + ": the scene differs from the one the run was started with, at line " +
                       std::to_string(line) + " of the scene as run: '" + la + "' then, '" + lb + "' now");
    a = ea + 1;
    b = eb + 1;
    ++line;
  }
}

/// Refuses (InputError, before anything is built) an output directory that cannot be one:
/// a path that names a file, a path under a file, or a directory that cannot be written into.
/// Nothing is left here (rank 0 creates the directory when it opens the record).
void check_output_directory(const std::string& out) {
  namespace fs = std::filesystem;
  std::error_code error;
  const fs::path dir = fs::absolute(fs::path(out), error);
  // The path itself, then its nearest existing ancestor: a directory that this process can write into.
  for (fs::path at = dir; !at.empty(); at = at.parent_path()) {
    const fs::file_status status = fs::status(at, error);
    if (!fs::exists(status)) {
      if (at == at.parent_path()) break;
      continue;
    }
    if (!fs::is_directory(status))
      throw InputError("--out: '" + out + "' " +
                       (at == dir ? std::string("is a file, not a directory")
                                  : "lies under '" + at.string() + "', which is a file, not a directory") +
                       "; name a directory (it is created if missing)");
    // Tried, not predicted: access() says yes to root everywhere, and /proc or a read-only
    // mount refuse only when asked. A directory of this process's own is made and removed.
    std::string probe = (at / ".peristat-out-XXXXXX").string();
    if (::mkdtemp(probe.data()) == nullptr)
      throw InputError("--out: cannot write into '" + at.string() + "' (" + std::strerror(errno) + ")" +
                       (at == dir ? "" : ", where '" + out + "' would be created"));
    fs::remove(probe, error);
    return;
  }
}

/// This process's part of the model: a rank's under mpirun; one process's is the whole model,
/// numbered by itself (whole_as_part()). Both run the same paths.
struct ProcessModel {
  ModelPart part;
  const Model& held() const { return part.model; }
};

/// The part this process holds (RunPlan::model); a rank's part keeps the `extra` particles too
/// (global ids: the partners of faces that slid towards it).
ProcessModel process_model(const Scene& scene, const RunPlan& plan, const Ranks& ranks,
                           const std::vector<std::int64_t>& extra = {}) {
  if (ranks.size() == 1) return {whole_as_part(discretise(scene))};
  return {part_model(scene, plan.model.rings, ranks.rank(), ranks.size(), extra)};
}

/// The problem's options for this process's part: its rows and global ids.
ProblemOptions process_problem_options(const Scene& scene, const RunPlan& plan, const ProcessModel& m,
                                       const Ranks& ranks) {
  return part_problem_options(scene, plan, m.part, ranks.rank());
}

/// What `run` and `check` print of how the model is spread over the ranks.
std::string held_text(const RunPlan& plan) { return "model in parts: " + plan.model.reason; }

/// Whether `run` says which closure tolerance it chose: exact contact with a failure
/// criterion and no tolerance given, where the choice moves the answer.
bool says_closure_tolerance(const Scene& scene) {
  const ContactOptions& c = scene.contact;
  return c.enabled && c.enforcement == ContactEnforcement::exact && scene.failure.enabled &&
         !c.closure_tolerance_given;
}

/// One `peristat run`: the objects it builds, in the order it builds them, one method per step
/// (run_command lists them). Under mpirun every rank makes every step alike (the model, the
/// problem, the solver and the record are collective on the parts); rank 0 alone writes and
/// prints.
class Run {
 public:
  explicit Run(const RunArguments& args)
      : m_args(args), m_ranks(parallel::process_ranks()), m_root(m_ranks->root()) {}

  /// The scene with the --set overrides and --solver.
  void parse_scene() {
    std::vector<Override> overrides = parse_overrides(m_args.overrides);
    if (!m_args.solver.empty()) overrides.push_back({"solver.type", m_args.solver});
    m_scene = peristat::parse_scene(m_args.scene, overrides);
    m_out = m_args.out.empty() ? "results/" + m_scene.name : m_args.out;
    check_output_directory(m_out);  // every rank alike: one message, exit 2, before any work
  }

  /// The choices of the run, once (`auto` becomes a solver here, from the size estimate,
  /// before the preflight estimates its memory; an explicit choice is kept), and the threads
  /// of each rank.
  void plan() {
    const int ranks = m_ranks->size();
    m_plan = resolve_run_plan(m_scene, ranks);
    m_estimate = estimate_size(m_scene, m_plan);
    start_large_runs_on_huge_pages(m_estimate);  // before anything is printed
    if (!m_plan.linear_auto.empty() && !m_args.quiet && m_root)
      std::printf("peristat: solver.linear auto: %s\n", m_plan.linear_auto.c_str());
    if (!m_plan.factors_auto.empty() && !m_args.quiet && m_root)
      std::printf("peristat: solver.krylov.factors auto: %s\n", m_plan.factors_auto.c_str());
    if (says_closure_tolerance(m_scene) && !m_args.quiet && m_root)
      std::printf("peristat: contact.closure_tolerance %s\n", m_scene.contact.closure_tolerance_auto.c_str());
    // Under mpirun Newton distributes its linear solves, ADR its pseudo-time steps
    // (docs/guide/distributed.md).
    if (ranks > 1 && m_plan.newton() && m_plan.linear != LinearSolverKind::belos)
      throw InputError("solver.linear: under mpirun with " + std::to_string(ranks) +
                       " ranks Newton distributes its work only with solver.linear=belos (this run has " +
                       std::string(to_string(m_plan.linear)) +
                       "); add --set solver.linear=belos, run ADR (--solver adr), or run without mpirun");
    if (ranks > 1 && !m_plan.newton() && m_scene.solver.adr.break_during && m_scene.failure.enabled)
      throw InputError("solver.adr.breaking: iterations runs in one process only (each rank relaxes its own "
                       "unknowns, and the criterion reads every family's); run without mpirun, or break bonds "
                       "between equilibria (breaking: equilibrium)");
    if (m_args.threads > 0)
      omp_set_num_threads(m_args.threads);
    else if (ranks > 1)  // the ranks share the machine's cores
      omp_set_num_threads(std::max(1, omp_get_num_procs() / ranks));
  }

  /// Refuses what cannot run or fit before anything is allocated; prints the warnings.
  void preflight() {
    m_t_start = wall_seconds();
    m_warnings = peristat::preflight(m_scene, m_plan, m_estimate);
    for (const std::string& w : m_warnings) std::fprintf(stderr, "WARNING: %s\n", w.c_str());
  }

  /// This process's model: the whole model, or the rank's part of it (with the particles the
  /// parts took in as the contact faces slid: grow_parts()).
  void build_model() { m_model = process_model(m_scene, m_plan, *m_ranks, m_extra); }

  /// The problem on it, and its size.
  void build_problem() {
    make_problem();
    if (m_plan.ranks > 1 && !m_args.quiet && m_root)
      std::printf("peristat: %s\n", held_text(m_plan).c_str());
  }

  /// The problem on this process's model, and the size of both.
  void make_problem() {
    m_problem = std::make_unique<QuasiStaticProblem>(
        m_model.held(), process_problem_options(m_scene, m_plan, m_model, *m_ranks), *m_ranks);
    m_size = measure(m_model.held(), *m_problem, &m_model.part);
  }

  /// The step solver (Newton and its linear solver, or ADR), and the whole model's view that
  /// rank 0 writes (gathered from the parts on a part).
  void make_solver() {
    m_solver = make_step_solver(m_scene, m_plan, *m_problem, m_linear, &m_model.part);
    m_view = std::make_unique<WholeView>(m_model.part, *m_ranks);
    m_method = m_linear ? "Newton, linear solver " + m_linear->name() : std::string("ADR");
  }

  /// With --resume, the state of the last converged step of the checkpoint (the same scene and
  /// options only); else the unloaded state.
  void resume_or_start() {
    m_checkpoint_path = m_out + "/" + m_scene.name + ".checkpoint.h5";
    m_checkpointed = m_args.resume;
    start_from_checkpoint(true);
  }

  /// The state of the checkpoint's last converged step when there is one (m_checkpointed;
  /// with `check_run`, refused unless it is this scene's with these options), else the
  /// unloaded state.
  void start_from_checkpoint(bool check_run) {
    m_x = VectorXd::Zero(m_problem->n_unknowns());
    m_steps_done = 0;
    if (!m_checkpointed) {
      m_problem->set_load_factor(0.0);
      return;
    }
    const StateArchive checkpoint = read_checkpoint(m_checkpoint_path);
    if (check_run) check_same_run(checkpoint, m_checkpoint_path, m_scene, m_args);
    m_x = m_view->unknowns_from(checkpoint.get("state/x", m_size.unknowns));  // the whole model's unknowns
    m_steps_done = static_cast<int>(checkpoint.scalar("state/steps_done"));
    m_problem->restore_state(checkpoint, m_x);
  }

  /// The contact faces slid past the parts (PartsOutgrown, thrown alike on every rank): each
  /// rank's part takes in the particles it named, the model, problem and solver are built
  /// again, and the run goes on from the last checkpoint, as a resumed run would (the
  /// checkpoint is by global id, so it restores on any parts).
  void grow_parts(const PartsOutgrown& grown) {
    ++m_regrowths;
    if (verbose())
      std::printf("peristat: %s; the parts take in %lld more particles and go on from %s\n", grown.what(),
                  static_cast<long long>(grown.total()),
                  m_checkpointed ? "the last checkpoint" : "the unloaded state");
    std::vector<std::int64_t> extra = m_extra;
    extra.insert(extra.end(), grown.particles().begin(), grown.particles().end());
    std::sort(extra.begin(), extra.end());
    extra.erase(std::unique(extra.begin(), extra.end()), extra.end());
    m_extra = std::move(extra);
    (void)m_ranks->any(false);  // a barrier: rank 0's checkpoint is on disk before the others read it
    m_solver.reset();  // in reverse order of construction
    m_linear.reset();
    m_view.reset();
    m_problem.reset();
    m_model = ProcessModel{};
    build_model();
    make_problem();
    make_solver();
    start_from_checkpoint(false);
    m_progress = std::make_unique<ProgressPrinter>(verbose(), m_plan.solver, *m_problem);
    m_recorder->rebind(*m_problem, *m_view);
    m_recorder->set_run_value("part_regrowths", m_regrowths);
    m_recorder->set_run_value("largest_rank_particles", m_size.largest_rank_particles);
  }

  /// The header, and the results record (HDF5, XDMF, summary.json) with the warnings.
  void open_record() {
    m_progress = std::make_unique<ProgressPrinter>(verbose(), m_plan.solver, *m_problem);
    m_progress->header(m_scene, m_size, wall_seconds() - m_t_start, m_method);
    m_recorder = std::make_unique<StepRecorder>(m_out, m_scene, *m_problem, *m_view, m_size,
                                                m_linear ? m_linear->name() : "", omp_get_max_threads(),
                                                m_args.resume ? m_steps_done : -1, m_root);
    for (const std::string& w : m_warnings) m_recorder->add_warning(w);
    if (m_args.resume && verbose())
      std::printf("peristat: resuming after load step %d/%d (load factor %.6g) from %s\n", m_steps_done,
                  m_scene.loading.steps, m_problem->load_factor(), m_checkpoint_path.c_str());
  }

  /// The load steps, each recorded and checkpointed; the exit code of how they ended. When the
  /// contact faces slide past the ranks' parts, the parts grow and the run goes on
  /// (grow_parts()).
  int run_load_steps_and_finish() {
    // Every nominal step: the results, then the checkpoint (a stop between the two repeats the step).
    StateArchive checkpoint;
    checkpoint.texts = {{"scene", m_scene.text}, {"overrides", joined(m_args.overrides)}, {"solver", m_args.solver}};
    class Observer final : public ProgressObserver {
     public:
      Observer(Run& run, StateArchive& checkpoint)
          : ProgressObserver(*run.m_progress), m_run(run), m_checkpoint(checkpoint) {}
      void step_done(const StepReport& step, const VectorXd& state) override {
        m_run.record_step(step, state, m_checkpoint);
      }

     private:
      Run& m_run;
      StateArchive& m_checkpoint;
    };
    return finish_run(
        *m_recorder,
        [&] {
          for (;;) {
            Observer observer(*this, checkpoint);  // made again after grow_parts(): a new printer
            try {
              return run_load_steps(*m_problem, *m_solver, m_x, m_scene.loading, observer, m_steps_done);
            } catch (const PartsOutgrown& grown) {
              grow_parts(grown);
            }
          }
        },
        verbose(), m_t_start);
  }

 private:
  bool verbose() const { return !m_args.quiet && m_root; }

  /// What a converged nominal step leaves: its results record, then the checkpoint.
  void record_step(const StepReport& step, const VectorXd& state, StateArchive& checkpoint) {
    m_recorder->record(step, state);
    if (m_recorder->due(step.step)) m_progress->step_done(step);
    checkpoint.arrays.clear();
    checkpoint.put("state/x", m_view->unknowns(state));  // collective on the parts
    checkpoint.put("state/steps_done", step.step);
    m_problem->save_state(checkpoint);
    if (m_root) write_checkpoint(m_checkpoint_path, checkpoint);
    m_checkpointed = true;
  }

  // In the order they are built (and destroyed in reverse: the solvers before the problem).
  const RunArguments& m_args;
  const std::unique_ptr<Ranks> m_ranks;  ///< this process's ranks: the one way to the others
  const bool m_root;
  Scene m_scene;
  RunPlan m_plan;
  SizeEstimate m_estimate;  // of m_plan: the huge-page decision and the preflight
  double m_t_start = 0.0;
  std::vector<std::string> m_warnings;
  ProcessModel m_model;
  std::unique_ptr<QuasiStaticProblem> m_problem;
  ModelSize m_size;
  std::unique_ptr<LinearSolver> m_linear;
  std::unique_ptr<StepSolver> m_solver;
  std::unique_ptr<WholeView> m_view;
  std::string m_method;
  std::string m_out, m_checkpoint_path;
  VectorXd m_x;
  int m_steps_done = 0;
  bool m_checkpointed = false;         ///< the checkpoint file holds a converged step of this run
  std::vector<std::int64_t> m_extra;   ///< particles the part took in as the faces slid (global ids)
  int m_regrowths = 0;                 ///< times the parts grew (grow_parts())
  std::unique_ptr<ProgressPrinter> m_progress;
  std::unique_ptr<StepRecorder> m_recorder;
};

}  // namespace

int check_command(const std::string& scene_path, const std::vector<std::string>& overrides) {
  Scene scene = parse_scene(scene_path, parse_overrides(overrides));
  const std::unique_ptr<Ranks> ranks = parallel::process_ranks();
  const RunPlan plan = resolve_run_plan(scene, ranks->size());
  const SizeEstimate estimate = estimate_size(scene, plan);
  start_large_runs_on_huge_pages(estimate);  // as `run` would (before anything is printed)
  for (const std::string& w : preflight(scene, plan, estimate)) std::fprintf(stderr, "WARNING: %s\n", w.c_str());
  const ProcessModel pm = process_model(scene, plan, *ranks);
  const Model& model = pm.held();
  const QuasiStaticProblem problem(model, process_problem_options(scene, plan, pm, *ranks), *ranks);
  const ModelSize size = measure(model, problem, &pm.part);
  if (!ranks->root()) return exit_success;
  std::printf("%s: scene '%s' is valid\n", scene_path.c_str(), scene.name.c_str());
  std::printf("  bodies         %zu, materials %zu, pre-cracks %zu, conditions %zu\n", scene.bodies.size(),
              scene.materials.size(), scene.cracks.size(), scene.boundary.size());
  std::printf("  spacing        %g m, horizon %g m (m = %g), %zu bonds per interior family\n", model.spacing,
              model.horizon, scene.discretization.horizon_factor, model.stencil.offset.size());
  print_size(size);
  if (!plan.linear_auto.empty()) std::printf("  solver.linear  auto: %s\n", plan.linear_auto.c_str());
  if (!plan.factors_auto.empty()) std::printf("  factors        auto: %s\n", plan.factors_auto.c_str());
  if (scene.contact.enabled && scene.contact.enforcement == ContactEnforcement::exact) {
    const ClosureReference r = scene.contact.closure_reference;
    const char* reference =
        r == ClosureReference::material
            ? "counted beyond the material's own compressive strain (closure_reference: "
              "material)"
        : r == ClosureReference::broken_bonds
            ? "counted beyond the material's own compressive strain on the faces of broken bonds, from the "
              "reference spacing elsewhere (closure_reference: broken_bonds)"
            : "counted from the reference spacing (closure_reference: spacing)";
    if (scene.contact.closure_tolerance_given)
      std::printf("  contact        exact, closure tolerance %g (given), %s\n",
                  scene.contact.closure_tolerance, reference);
    else
      std::printf("  contact        exact, closure tolerance %s, %s\n",
                  scene.contact.closure_tolerance_auto.c_str(), reference);
  }
  if (ranks->size() > 1) std::printf("  ranks          %s\n", held_text(plan).c_str());
  std::printf("  estimate       %.3g particles, %.3g nonzeros, %.1f MB before discretising (%.1f MB available)\n",
              estimate.particles + estimate.fictitious, estimate.nonzeros, estimate.memory_bytes / 1e6,
              estimate.available_bytes / 1e6);
  std::printf("  huge pages     malloc's large blocks: %s\n", malloc_huge_pages_state().c_str());
  if (estimate.factor_nonzeros > 0.0)
    std::printf("  factorisation  of %s: about %.3g factor nonzeros, %.1f MB more (estimated)\n",
                estimate.factor_of.c_str(), estimate.factor_nonzeros, estimate.factor_bytes / 1e6);
  else if (estimate.factor_bytes > 0.0)
    std::printf("  solver         %s: %.1f MB more (estimated)\n", estimate.factor_of.c_str(),
                estimate.factor_bytes / 1e6);
  return exit_success;
}

/// The steps of a run (deal.II step-44's run()).
int run_command(const RunArguments& args) {
  Run run(args);
  run.parse_scene();
  run.plan();
  run.preflight();
  run.build_model();
  run.build_problem();
  run.make_solver();
  run.resume_or_start();
  run.open_record();
  return run.run_load_steps_and_finish();
}

int probe_command(const ProbeArguments& args) {
  if (args.points < 2) throw InputError("--points: expected at least 2, got " + std::to_string(args.points));
  std::optional<ResultsReader> opened;
  try {
    opened.emplace(args.results);
  } catch (const std::runtime_error& e) {
    throw InputError(e.what());  // a missing or foreign file is the user's input
  }
  const ResultsReader& reader = *opened;
  if (reader.steps().empty()) throw InputError(args.results + ": the file holds no converged step");
  const int step = args.step < 0 ? reader.steps().back() : args.step;
  const auto& steps = reader.steps();
  if (std::find(steps.begin(), steps.end(), step) == steps.end()) {
    throw InputError(args.results + ": --step " + std::to_string(step) + " is not in the file (steps " +
                     std::to_string(steps.front()) + " to " + std::to_string(steps.back()) + ")");
  }
  const auto samples = probe_line(reader, step, Vec2(args.x0, args.y0), Vec2(args.x1, args.y1), args.points);
  std::printf("s,x,y,ux,uy\n");
  for (const ProbeSample& p : samples)
    std::printf("%.10g,%.10g,%.10g,%.10g,%.10g\n", p.s, p.x, p.y, p.ux, p.uy);
  return exit_success;
}

}  // namespace peristat
