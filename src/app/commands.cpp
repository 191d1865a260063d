#include "app/commands.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>

#include <nlohmann/json.hpp>
#include <omp.h>

#include "app/interrupt.hpp"
#include "assembly/quasi_static.hpp"
#include "core/clock.hpp"
#include "core/error.hpp"
#include "discretisation/model.hpp"
#include "io/results.hpp"
#include "solvers/adr.hpp"
#include "solvers/linear/linear_solver.hpp"
#include "solvers/load_stepping.hpp"
#include "solvers/newton.hpp"

namespace peristat {

namespace {

std::vector<Override> parse_overrides(const std::vector<std::string>& assignments) {
  std::vector<Override> out;
  for (const std::string& a : assignments) out.push_back(parse_override(a));
  return out;
}

/// Model size figures printed by `check` and `run` and stored in summary.json.
struct ModelSize {
  Index particles = 0, fictitious = 0, bonds = 0, cut_bonds = 0, unknowns = 0, prescribed = 0;
  long long nonzeros = 0;
  double memory_bytes = 0.0;  ///< model + bond caches + tangent (factorisation excluded)
};

ModelSize measure(const Model& model, const TangentPattern& pattern) {
  ModelSize s;
  const Particles& p = model.particles;
  s.particles = p.size();
  for (char f : p.fictitious) s.fictitious += f;
  s.bonds = model.bonds.n_bonds() / 2;
  s.cut_bonds = model.n_cut_bonds;
  s.unknowns = model.constraints.n_free;
  s.prescribed = 2 * p.size() - s.unknowns;
  s.nonzeros = pattern.matrix.nonZeros();
  const double per_particle = sizeof(Vec2) + 2 * sizeof(double) + sizeof(int) + 1 + 2 * sizeof(int) +
                              4 * (sizeof(char) + sizeof(double) + sizeof(Index)) +        // constraints
                              4 * sizeof(double) + 2 * sizeof(Vec2) + 2 * sizeof(double);  // state
  const double per_bond = 2 * sizeof(Index) + sizeof(Vec2) + sizeof(double) +              // bonds
                          3 * sizeof(Vec2) + sizeof(double) + 3 * sizeof(double);          // caches
  const double matrix =
      s.nonzeros * (sizeof(double) + sizeof(Index)) + pattern.row_particle.size() * 2.0 * sizeof(Index);
  s.memory_bytes = per_particle * p.size() + per_bond * model.bonds.n_bonds() + matrix;
  return s;
}

void print_size(const ModelSize& s) {
  std::printf("  particles      %d (%d fictitious)\n", s.particles, s.fictitious);
  std::printf("  bonds          %d (%d cut by pre-cracks)\n", s.bonds, s.cut_bonds);
  std::printf("  unknowns       %d (%d prescribed components)\n", s.unknowns, s.prescribed);
  std::printf("  tangent        %lld nonzeros\n", s.nonzeros);
  std::printf("  memory         %.1f MB for model, bonds and tangent (factorisation not included)\n",
              s.memory_bytes / 1e6);
}

/// The resolved options and model size, stored under "run" in summary.json.
std::string run_info_json(const Scene& scene, const ModelSize& s, const std::string& linear, int threads) {
  const NewtonOptions& n = scene.solver.newton;
  nlohmann::ordered_json solver = {{"type", to_string(scene.solver.type)}};
  if (scene.solver.type == SolverKind::adr) {
    const AdrOptions& a = scene.solver.adr;
    solver["adr_rtol"] = a.rtol;
    solver["adr_max_iterations"] = static_cast<double>(a.max_iterations);  // a double, as always written
    solver["adr_on_budget"] = a.accept_on_budget ? "accept" : "fail";
    solver["adr_density_factor"] = a.density_factor;
  } else {
    solver["linear"] = linear;
    solver["newton_rtol"] = n.rtol;
    solver["newton_atol"] = n.atol;
    solver["newton_max_iterations"] = n.max_iterations;
    solver["line_search"] = n.line_search;
    solver["tangent"] = n.tangent == TangentKind::consistent ? "consistent" : "initial";
  }
  const nlohmann::ordered_json info = {{"particles", s.particles},
                                       {"fictitious", s.fictitious},
                                       {"bonds", s.bonds},
                                       {"cut_bonds", s.cut_bonds},
                                       {"unknowns", s.unknowns},
                                       {"tangent_nonzeros", s.nonzeros},
                                       {"threads", threads},
                                       {"spacing", scene.discretization.spacing},
                                       {"horizon_factor", scene.discretization.horizon_factor},
                                       {"load_steps", scene.loading.steps},
                                       {"solver", solver}};
  return info.dump();
}

ParticleTable particle_table(const Scene& scene, const Model& model) {
  ParticleTable t;
  const Particles& p = model.particles;
  t.position = p.position;
  t.volume = p.volume;
  t.body = p.body;
  t.fictitious.assign(p.fictitious.begin(), p.fictitious.end());
  for (const Body& b : scene.bodies) t.body_names.push_back(b.name);
  t.spacing = model.spacing;
  return t;
}

}  // namespace

int check_command(const std::string& scene_path, const std::vector<std::string>& overrides) {
  const Scene scene = parse_scene(scene_path, parse_overrides(overrides));
  const Model model = discretise(scene);
  const TangentPattern pattern = build_pattern(model);
  std::printf("%s: scene '%s' is valid\n", scene_path.c_str(), scene.name.c_str());
  std::printf("  bodies         %zu, materials %zu, pre-cracks %zu, conditions %zu\n", scene.bodies.size(),
              scene.materials.size(), scene.cracks.size(), scene.boundary.size());
  std::printf("  spacing        %g m, horizon %g m (m = %g), %zu bonds per interior family\n", model.spacing,
              model.horizon, scene.discretization.horizon_factor, model.stencil.offset.size());
  print_size(measure(model, pattern));
  return exit_success;
}

int run_command(const RunArguments& args) {
  std::vector<Override> overrides = parse_overrides(args.overrides);
  if (!args.solver.empty()) overrides.push_back({"solver.type", args.solver});
  const Scene scene = parse_scene(args.scene, overrides);
  const bool adr = scene.solver.type == SolverKind::adr;
  if (args.threads > 0) omp_set_num_threads(args.threads);
  const bool verbose = !args.quiet;
  const double t_start = wall_seconds();

  const Model model = discretise(scene);
  QuasiStaticProblem problem(model, scene);
  // Measured before a solver takes the tangent's pattern over.
  const ModelSize size = measure(model, problem.pattern());
  std::unique_ptr<LinearSolver> linear;
  std::unique_ptr<StepSolver> solver;
  if (adr) {
    solver = std::make_unique<AdrSolver>(problem, scene.solver.adr);
  } else {
    linear = make_linear_solver(scene.solver.linear);
    solver = std::make_unique<NewtonSolver>(problem, *linear, scene.solver.newton);
  }
  const std::string method = adr ? std::string("ADR") : "Newton, linear solver " + linear->name();
  const double t_model = wall_seconds() - t_start;
  if (verbose) {
    std::printf("peristat: %s (%s)\n", scene.name.c_str(), scene.path.c_str());
    print_size(size);
    std::printf("  model built in %.2f s; %s, %d threads\n", t_model, method.c_str(), omp_get_max_threads());
    if (adr)
      std::printf("  ADR: rtol %.1e, budget %ld iterations per step (%s when exhausted)\n", scene.solver.adr.rtol,
                  scene.solver.adr.max_iterations, scene.solver.adr.accept_on_budget ? "keep the state" : "stop");
  }

  const std::string out = args.out.empty() ? "results/" + scene.name : args.out;
  ResultsWriter writer(out, scene.name, scene.text, particle_table(scene, model),
                       run_info_json(scene, size, linear ? linear->name() : "", omp_get_max_threads()));

  const ContactSystem* contact = problem.contact();
  double contact_seconds_before = 0.0;  // contact evaluation time up to the previous step
  VectorXd contact_force, damage;
  if (verbose && contact) {
    std::printf("  contact        %d candidate pairs (found in %.3f s), radius %g m, %s law, friction %g\n",
                contact->size(), problem.contact_setup_seconds(), contact->law().radius,
                scene.contact.normal == NormalLaw::paper ? "paper" : "pair", contact->law().friction);
  }
  VectorXd x = VectorXd::Zero(problem.n_unknowns());
  VectorXd u;
  problem.set_load_factor(0.0);

  LoadSteppingCallbacks cb;
  auto check_interrupt = [] {
    if (const int sig = interrupt_signal()) throw Interrupted{sig};
  };
  cb.on_attempt = [&](int k, int n, double lambda, int cutbacks) {
    check_interrupt();
    if (verbose) {
      std::printf("step %d/%d  load factor %.6g%s\n", k, n, lambda, cutbacks ? "  (after cut-back)" : "");
      std::fflush(stdout);
    }
  };
  cb.on_iteration = [&](int it, double rel, double extra) {
    check_interrupt();
    if (!verbose) return;
    if (adr)
      std::printf("  adr %9d  residual %.3e  damping %.4f", it, rel, extra);
    else if (it == 0)
      std::printf("  newton %2d  residual %.3e", it, rel);
    else
      std::printf("  newton %2d  residual %.3e  step %.3g", it, rel, extra);
    if (contact) {
      const ContactCounts& c = contact->counts();
      std::printf("  contact open %d stick %d slip %d", c.open, c.stick, c.slip);
    }
    std::printf("\n");
    std::fflush(stdout);
  };
  cb.on_resolve = [&](Index broken, int resolve) {
    check_interrupt();
    if (verbose) {
      std::printf("  %ld bonds broke (%ld in all); re-solve %d at the same load\n", static_cast<long>(broken),
                  static_cast<long>(problem.broken_bonds()), resolve);
      std::fflush(stdout);
    }
  };
  cb.on_break_cutback = [&](const std::string& reason, Index broken, Index next) {
    if (verbose) {
      std::printf("  re-solve failed (%s): the %ld bonds are restored; retrying with the %ld most critical\n",
                  reason.c_str(), static_cast<long>(broken), static_cast<long>(next));
      std::fflush(stdout);
    }
  };
  cb.on_cutback = [&](const std::string& reason, double next) {
    if (verbose) std::printf("  cut-back: %s; next increment %.4g\n", reason.c_str(), next);
  };
  cb.on_step = [&](const StepReport& s, const VectorXd& state) {
    const double step_contact_seconds = problem.contact_seconds() - contact_seconds_before;
    contact_seconds_before = problem.contact_seconds();
    if (s.step % scene.output.every != 0 && s.step != scene.loading.steps) return;
    problem.expand(state, u);
    StepRecord rec;
    rec.index = s.step;
    rec.load_factor = s.load_factor;
    rec.newton_iterations = s.newton_iterations;
    rec.active_set_iterations = s.active_set_changes;
    rec.residual_norm = s.final_residual;
    rec.wall_seconds = s.wall_seconds;
    rec.displacement = &u;
    rec.residual_history = s.residuals;
    rec.counts = {{"substeps", s.substeps},
                  {"cutbacks", s.cutbacks},
                  {"factorizations", s.factorizations},
                  {"linear_iterations", s.linear_iterations}};
    if (problem.models_failure()) {
      problem.damage(damage);
      rec.damage = &damage;
      rec.counts["bonds_broken"] = s.bonds_broken;
      rec.counts["broken_bonds_total"] = problem.broken_bonds();
      rec.counts["resolves"] = s.resolves;
      rec.counts["break_cutbacks"] = s.break_cutbacks;
    }
    if (adr) {
      rec.counts["adr_iterations"] = s.newton_iterations;
      rec.counts["unconverged_substeps"] = s.unconverged;
    }
    if (contact) {
      // The commit evaluated the pairs at this state (before updating the slip history).
      contact->contact_force(contact_force);
      rec.contact_force = &contact_force;
      const ContactCounts& c = contact->counts();
      rec.counts["contact_candidates"] = c.candidates;
      rec.counts["contact_open"] = c.open;
      rec.counts["contact_stick"] = c.stick;
      rec.counts["contact_slip"] = c.slip;
      rec.counts["contact_min_distance"] = contact->min_distance();
    }
    rec.timings = {
        {"evaluate", s.seconds_evaluate}, {"factorize", s.seconds_factorize}, {"solve", s.seconds_solve}};
    if (contact) rec.timings["contact"] = step_contact_seconds;
    const WriteGuard guard;
    writer.write_step(rec);
    if (verbose && contact) {
      const ContactCounts& c = contact->counts();
      std::printf("  contact: %d open, %d stick, %d slip of %d pairs; active set changed in %d iterations; "
                  "closest pair %.3g dx\n",
                  c.open, c.stick, c.slip, c.candidates, s.active_set_changes,
                  contact->min_distance() / model.spacing);
    }
    if (verbose && problem.models_failure())
      std::printf("  failure: %ld bonds broke in this step (%d re-solves, %d halved after a failed re-solve), "
                  "%ld in all\n",
                  static_cast<long>(s.bonds_broken), s.resolves, s.break_cutbacks,
                  static_cast<long>(problem.broken_bonds()));
    if (verbose && adr) {
      std::printf("  %s: %d ADR iterations, relative residual %.3e; %.2f s (force evaluations %.2f s)\n",
                  s.unconverged ? "NOT converged, kept (on_budget: accept)" : "converged", s.newton_iterations,
                  s.final_residual, s.wall_seconds, s.seconds_evaluate);
    } else if (verbose) {
      std::printf(
          "  converged: %d Newton iterations, %d factorisations, %d Krylov iterations; %.2f s "
          "(assembly %.2f incl. contact, factorisation %.2f, solves %.2f)\n",
          s.newton_iterations, s.factorizations, s.linear_iterations, s.wall_seconds, s.seconds_evaluate,
          s.seconds_factorize, s.seconds_solve);
    }
  };

  install_interrupt_handlers();
  RunReport report;
  try {
    report = run_load_steps(problem, *solver, x, scene.loading, cb);
  } catch (const Interrupted& stop) {
    const std::string message = "interrupted by signal " + std::to_string(stop.signal);
    writer.finish("interrupted", message);
    std::fprintf(stderr, "peristat: %s; converged steps kept in %s\n", message.c_str(),
                 writer.h5_path().c_str());
    return 128 + stop.signal;
  }
  if (!report.completed) {
    writer.finish("no_convergence", report.message);
    std::fprintf(stderr, "peristat: %s; %d converged step(s) kept in %s\n", report.message.c_str(),
                 report.steps_done, writer.h5_path().c_str());
    return exit_no_convergence;
  }
  writer.finish("completed", "completed");
  if (verbose)
    std::printf("peristat: done in %.2f s; results in %s\n", wall_seconds() - t_start,
                writer.h5_path().c_str());
  return exit_success;
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
