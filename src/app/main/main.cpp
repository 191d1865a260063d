// peristat: quasi-static peridynamics with frictional contact. Exit codes: 0 success,
// 1 internal error (for compare: the difference exceeds --tol), 2 bad input or usage,
// 3 no convergence (README.md, "Using it").
#include <cstdio>
#include <exception>

#include <CLI/CLI.hpp>

#include "app/commands.hpp"
#include "app/linear_solvers.hpp"
#include "core/error.hpp"
#include "core/version.hpp"
#include "parallel/mpi/mpi_ranks.hpp"

int main(int argc, char** argv) {
  using namespace peristat;
  // Under mpirun: MPI starts now, and the ranks other than 0 print nothing (they run the same
  // model; docs/guide/distributed.md).
  const parallel::Session mpi;
  register_linear_solvers();  // belos and the bond_amg V-cycle behind the linear-solver seam
  if (parallel::process_ranks()->rank() > 0) {
    std::FILE* out = std::freopen("/dev/null", "w", stdout);
    std::FILE* err = std::freopen("/dev/null", "w", stderr);
    (void)out;
    (void)err;
  }
  CLI::App app{"peristat: quasi-static state-based peridynamics (Newton on a consistent tangent)"};
  app.require_subcommand(1);
  app.set_version_flag("--version", program_description(), "print peristat's version and commit, and exit");

  RunArguments run;
  CLI::App* run_cmd = app.add_subcommand("run", "solve a scene load step by load step");
  run_cmd->add_option("scene", run.scene, "scene file (YAML)")->required();
  run_cmd->add_option("--out", run.out, "output directory (default results/<scene name>)");
  run_cmd->add_option("--solver", run.solver, "newton or adr (overrides solver.type)");
  run_cmd->add_option("--set", run.overrides, "override a scene key: --set solver.linear=umfpack")
      ->take_all()
      ->allow_extra_args(false);
  run_cmd->add_flag("--quiet", run.quiet, "no progress output");
  run_cmd->add_flag("--resume", run.resume,
                    "continue the stopped run in --out from its last converged load step (same scene and options)");
  run_cmd->add_option("--threads", run.threads, "OpenMP threads for assembly (default: all cores)")
      ->check(CLI::PositiveNumber);

  std::string check_scene;
  std::vector<std::string> check_overrides;
  CLI::App* check_cmd = app.add_subcommand("check", "validate a scene and print the model size");
  check_cmd->add_option("scene", check_scene, "scene file (YAML)")->required();
  check_cmd->add_option("--set", check_overrides, "override a scene key")
      ->take_all()
      ->allow_extra_args(false);

  ProbeArguments probe;
  std::vector<double> line;
  CLI::App* probe_cmd = app.add_subcommand("probe", "CSV line profile s,x,y,ux,uy of a results file");
  probe_cmd->add_option("results", probe.results, "results file (.h5)")->required();
  probe_cmd->add_option("--line", line, "X0 Y0 X1 Y1 (reference coordinates)")->expected(4)->required();
  probe_cmd->add_option("--step", probe.step, "step number (default: last)");
  probe_cmd->add_option("--points", probe.points, "number of samples (default 101)");

  CompareArguments compare;
  int compare_step = 0;
  double compare_tol = 0.0;
  CLI::App* compare_cmd =
      app.add_subcommand("compare", "displacement difference of A against the reference B (same particles)");
  compare_cmd->add_option("a", compare.a, "results file (.h5)")->required();
  compare_cmd->add_option("b", compare.b, "reference results file (.h5)")->required();
  CLI::Option* compare_step_opt =
      compare_cmd->add_option("--step", compare_step, "step K of both files (default: the last of each)");
  CLI::Option* compare_tol_opt =
      compare_cmd->add_option("--tol", compare_tol, "exit code 1 when the relative L2 difference exceeds T");
  compare_cmd->add_flag("--json", compare.json, "print one JSON object");

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? exit_success : exit_bad_input;
  }

  try {
    if (*run_cmd) return run_command(run);
    if (*check_cmd) return check_command(check_scene, check_overrides);
    if (*probe_cmd) {
      probe.x0 = line[0];
      probe.y0 = line[1];
      probe.x1 = line[2];
      probe.y1 = line[3];
      return probe_command(probe);
    }
    if (*compare_cmd) {
      if (compare_step_opt->count() > 0) compare.step = compare_step;
      if (compare_tol_opt->count() > 0) compare.tol = compare_tol;
      return compare_command(compare);
    }
  } catch (const InputError& e) {
    std::fprintf(stderr, "peristat: error: %s\n", e.what());
    return exit_bad_input;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "peristat: internal error: %s\n", e.what());
    std::fflush(stderr);
    parallel::abort_if_distributed(exit_internal_error);
    return exit_internal_error;
  }
  return exit_internal_error;
}
