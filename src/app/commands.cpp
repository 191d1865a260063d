#include "app/commands.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <memory>
#include <optional>

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
#include "discretisation/model.hpp"
#include "io/checkpoint.hpp"
#include "io/results.hpp"
#include "solvers/adr.hpp"
#include "solvers/linear/linear_solver.hpp"
#include "solvers/load_stepping.hpp"
#include "solvers/newton.hpp"
#include "solvers/trilinos/parallel.hpp"

namespace peristat {

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

/// This process's model and the rows it owns: under mpirun on the parts (solver.belos.model),
/// the rank's part of the model; with partitioned bonds, the whole particle table with the
/// families of the rank's rows and their neighbours only (docs/guide/distributed.md), so that
/// `check` measures what `run` will hold.
struct ProcessModel {
  Model model;
  std::optional<ModelPart> part;
  OwnedRows rows;
  BondsChoice bonds;
  ModelChoice choice;
  const Model& held() const { return part ? part->model : model; }
  const ModelPart* part_or_null() const { return part ? &*part : nullptr; }
};

ProcessModel process_model(const Scene& scene) {
  ProcessModel m;
  const int ranks = parallel::size();
  m.choice = part_model_choice(scene, ranks);
  if (m.choice.part) {
    m.part.emplace(part_model(scene, parallel::rank(), ranks));
    m.bonds = {
        true, part_rings(scene),
        part_rings(scene) == 1
            ? "a rank's part holds the families of its particles and their neighbours"
            : "a rank's part holds the families of its particles and of two rings around them (an assembled "
              "tangent)"};
    return m;
  }
  m.bonds = partitioned_bonds(scene, ranks);
  if (m.bonds.partitioned) {
    m.model = discretise(scene, [&](const Model& unbonded) {
      m.rows = owned_rows(scene, unbonded, parallel::rank(), ranks);
      return families_to_hold(unbonded, m.rows, m.bonds.rings);
    });
  } else {
    m.model = discretise(scene);
    m.rows = owned_rows(scene, m.model, parallel::rank(), ranks);
  }
  return m;
}

/// The problem's options for this process: under mpirun, the rank's own rows.
ProblemOptions process_problem_options(const Scene& scene, const ProcessModel& m) {
  if (m.part) return part_problem_options(scene, *m.part, parallel::rank());
  ProblemOptions options = problem_options(scene);
  if (parallel::size() > 1) {
    options.rows = m.rows;
    options.max_over_ranks = parallel::max_over_ranks;
    options.sum_over_ranks = [](double v) { return parallel::sum_over_ranks(v); };
    if (m.bonds.partitioned) {
      options.share_forces = force_exchange(m.rows);
      options.gather_over_ranks = parallel::gather_over_ranks;
      options.share_particle_values = particle_exchange(m.rows);
    }
  }
  return options;
}

/// What `run` and `check` print of how the model is spread over the ranks.
std::string held_text(const ProcessModel& m) {
  if (m.part) return "model in parts: " + m.choice.reason;
  return std::string("bonds ") + (m.bonds.partitioned ? "partitioned" : "whole") + ": " + m.bonds.reason +
         (m.choice.reason.empty() || m.choice.reason == "solver.belos.model: whole"
              ? std::string()
              : "; the whole particle table on every rank (" + m.choice.reason + ")");
}

}  // namespace

int check_command(const std::string& scene_path, const std::vector<std::string>& overrides) {
  Scene scene = parse_scene(scene_path, parse_overrides(overrides));
  const std::string linear_choice =
      resolve_linear_solver(scene, parallel::size());
  const SizeEstimate estimate = estimate_size(scene);
  for (const std::string& w : preflight(scene, estimate)) std::fprintf(stderr, "WARNING: %s\n", w.c_str());
  const ProcessModel pm = process_model(scene);
  const Model& model = pm.held();
  const QuasiStaticProblem problem(model, process_problem_options(scene, pm));
  const ModelSize size = measure(model, problem, pm.part_or_null());
  if (parallel::rank() != 0) return exit_success;
  std::printf("%s: scene '%s' is valid\n", scene_path.c_str(), scene.name.c_str());
  std::printf("  bodies         %zu, materials %zu, pre-cracks %zu, conditions %zu\n", scene.bodies.size(),
              scene.materials.size(), scene.cracks.size(), scene.boundary.size());
  std::printf("  spacing        %g m, horizon %g m (m = %g), %zu bonds per interior family\n", model.spacing,
              model.horizon, scene.discretization.horizon_factor, model.stencil.offset.size());
  print_size(size);
  if (!linear_choice.empty()) std::printf("  solver.linear  auto: %s\n", linear_choice.c_str());
  if (parallel::size() > 1 || pm.part) std::printf("  ranks          %s\n", held_text(pm).c_str());
  std::printf("  estimate       %.3g particles, %.3g nonzeros, %.1f MB before discretising (%.1f MB available)\n",
              estimate.particles + estimate.fictitious, estimate.nonzeros, estimate.memory_bytes / 1e6,
              estimate.available_bytes / 1e6);
  if (estimate.factor_nonzeros > 0.0)
    std::printf("  factorisation  of %s: about %.3g factor nonzeros, %.1f MB more (estimated)\n",
                estimate.factor_of.c_str(), estimate.factor_nonzeros, estimate.factor_bytes / 1e6);
  else if (estimate.factor_bytes > 0.0)
    std::printf("  solver         %s: %.1f MB more (estimated)\n", estimate.factor_of.c_str(),
                estimate.factor_bytes / 1e6);
  return exit_success;
}

int run_command(const RunArguments& args) {
  std::vector<Override> overrides = parse_overrides(args.overrides);
  if (!args.solver.empty()) overrides.push_back({"solver.type", args.solver});
  Scene scene = parse_scene(args.scene, overrides);
  // Under mpirun every rank holds the same model; Newton distributes its linear solves, ADR
  // its pseudo-time steps (docs/guide/distributed.md); rank 0 alone writes and prints.
  const int ranks = parallel::size();
  const bool root = parallel::rank() == 0;
  // solver.linear: auto becomes a solver here, from the size estimate, before the preflight
  // estimates its memory (an explicit choice is kept).
  const std::string linear_choice = resolve_linear_solver(scene, ranks);
  if (!linear_choice.empty() && !args.quiet && root) std::printf("peristat: solver.linear auto: %s\n", linear_choice.c_str());
  if (ranks > 1 && scene.solver.type == SolverKind::newton &&
      scene.solver.linear.type != LinearSolverKind::belos)
    throw InputError("solver.linear: under mpirun with " + std::to_string(ranks) +
                     " ranks Newton distributes its work only with solver.linear=belos (this run has " +
                     std::string(to_string(scene.solver.linear.type)) +
                     "); add --set solver.linear=belos, run ADR (--solver adr), or run without mpirun");
  if (args.threads > 0)
    omp_set_num_threads(args.threads);
  else if (ranks > 1)  // the ranks share the machine's cores
    omp_set_num_threads(std::max(1, omp_get_num_procs() / ranks));
  const double t_start = wall_seconds();
  const std::vector<std::string> warnings = preflight(scene, estimate_size(scene));
  for (const std::string& w : warnings) std::fprintf(stderr, "WARNING: %s\n", w.c_str());

  const ProcessModel pm = process_model(scene);
  const Model& model = pm.held();
  QuasiStaticProblem problem(model, process_problem_options(scene, pm));
  if ((ranks > 1 || pm.part) && !args.quiet && root) std::printf("peristat: %s\n", held_text(pm).c_str());
  const ModelSize size = measure(model, problem, pm.part_or_null());
  std::unique_ptr<LinearSolver> linear;
  const std::unique_ptr<StepSolver> solver = make_step_solver(scene, problem, linear, pm.part_or_null());
  // What rank 0 writes is the whole model's: gathered from the parts on a part.
  const WholeView view(model, pm.part_or_null(), parallel::rank());
  const std::string method = linear ? "Newton, linear solver " + linear->name() : std::string("ADR");

  const std::string out = args.out.empty() ? "results/" + scene.name : args.out;
  const std::string checkpoint_path = out + "/" + scene.name + ".checkpoint.h5";
  VectorXd x = VectorXd::Zero(problem.n_unknowns());
  int steps_done = 0;
  if (args.resume) {
    const StateArchive checkpoint = read_checkpoint(checkpoint_path);
    check_same_run(checkpoint, checkpoint_path, scene, args);
    x = view.unknowns_from(checkpoint.get("state/x", size.unknowns));  // the whole model's unknowns
    steps_done = static_cast<int>(checkpoint.scalar("state/steps_done"));
    problem.restore_state(checkpoint, x);
  } else {
    problem.set_load_factor(0.0);
  }

  const bool verbose = !args.quiet && root;
  const ProgressPrinter progress(verbose, scene.solver.type, problem);
  progress.header(scene, size, wall_seconds() - t_start, method);
  StepRecorder recorder(out, scene, problem, view, size, linear ? linear->name() : "", omp_get_max_threads(),
                        args.resume ? steps_done : -1, root);
  for (const std::string& w : warnings) recorder.add_warning(w);
  if (args.resume && verbose)
    std::printf("peristat: resuming after load step %d/%d (load factor %.6g) from %s\n", steps_done,
                scene.loading.steps, problem.load_factor(), checkpoint_path.c_str());

  // Every nominal step: the results, then the checkpoint (a stop between the two repeats the step).
  StateArchive checkpoint;
  checkpoint.texts = {{"scene", scene.text}, {"overrides", joined(args.overrides)}, {"solver", args.solver}};
  LoadSteppingCallbacks callbacks = progress.callbacks();
  callbacks.on_step = [&](const StepReport& step, const VectorXd& state) {
    recorder.record(step, state);
    if (recorder.due(step.step)) progress.step_done(step);
    checkpoint.arrays.clear();
    checkpoint.put("state/x", view.unknowns(state));  // collective on the parts
    checkpoint.put("state/steps_done", step.step);
    problem.save_state(checkpoint);
    if (root) write_checkpoint(checkpoint_path, checkpoint);
  };
  return finish_run(
      recorder, [&] { return run_load_steps(problem, *solver, x, scene.loading, callbacks, steps_done); },
      verbose, t_start);
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
