// peristat: quasi-static peridynamics with frictional contact. Exit codes: 0 success,
// 1 internal error (for compare: the difference exceeds --tol), 2 bad input or usage,
// 3 no convergence (docs/guide/scene.md, "The command line").
#include <cstdio>
#include <exception>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "app/commands.hpp"
#include "app/linear_solvers.hpp"
#include "core/error.hpp"
#include "core/huge_pages.hpp"
#include "core/version.hpp"
#include "parallel/mpi/mpi_ranks.hpp"

namespace peristat {
namespace {

/// The subcommands' arguments and their CLI11 objects (CLI11 keeps references to the fields,
/// so a CommandLine stays where it was made).
struct CommandLine {
  RunArguments run;
  CLI::App* run_cmd = nullptr;
  std::string check_scene;
  std::vector<std::string> check_overrides;
  CLI::App* check_cmd = nullptr;
  ProbeArguments probe;
  std::vector<double> line;
  CLI::App* probe_cmd = nullptr;
  CompareArguments compare;
  int compare_step = 0;
  double compare_tol = 0.0;
  CLI::App* compare_cmd = nullptr;
  CLI::Option* compare_step_opt = nullptr;
  CLI::Option* compare_tol_opt = nullptr;
};

/// Under mpirun: the ranks other than 0 print nothing (they run the same model).
void silence_other_ranks() {
  if (parallel::process_ranks()->rank() > 0) {
    std::FILE* out = std::freopen("/dev/null", "w", stdout);
    std::FILE* err = std::freopen("/dev/null", "w", stderr);
    (void)out;
    (void)err;
  }
}

/// Adds `peristat run` and its options to `app`.
void add_run_command(CLI::App& app, CommandLine& c) {
  RunArguments& run = c.run;
  CLI::App* run_cmd = c.run_cmd = app.add_subcommand("run", "solve a scene load step by load step");
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
  run_cmd->footer(
      "Example:\n  peristat run cases/paper_4_3_precracked_plate/scene.yaml --out out --set "
      "solver.linear=umfpack\n"
      "writes out/paper_4_3_precracked_plate.h5 and .xdmf (open the .xdmf in ParaView).\n"
      "Exit codes: 0 completed, 2 bad input, 3 not converged (the reason is printed), 128 + signal when "
      "stopped.");
}

/// Adds `peristat check`, `probe` and `compare` and their options to `app`.
void add_other_commands(CLI::App& app, CommandLine& c) {
  CLI::App* check_cmd = c.check_cmd = app.add_subcommand("check", "validate a scene and print the model size");
  check_cmd->add_option("scene", c.check_scene, "scene file (YAML)")->required();
  check_cmd->add_option("--set", c.check_overrides, "override a scene key")
      ->take_all()
      ->allow_extra_args(false);
  check_cmd->footer(
      "Example:\n  peristat check cases/paper_4_4_crack_growth/scene.yaml --set discretization.spacing=0.02");

  ProbeArguments& probe = c.probe;
  CLI::App* probe_cmd = c.probe_cmd =
      app.add_subcommand("probe", "CSV line profile s,x,y,ux,uy of a results file");
  probe_cmd->add_option("results", probe.results, "results file (.h5)")->required();
  probe_cmd->add_option("--line", c.line, "X0 Y0 X1 Y1 (reference coordinates)")->expected(4)->required();
  probe_cmd->add_option("--step", probe.step, "step number (default: last)");
  probe_cmd->add_option("--points", probe.points, "number of samples (default 101)");
  probe_cmd->footer(
      "Example:\n  peristat probe out/tension_plate.h5 --line 0 0.05 0.1 0.05 --points 11 > profile.csv");

  CompareArguments& compare = c.compare;
  CLI::App* compare_cmd = c.compare_cmd =
      app.add_subcommand("compare", "displacement difference of A against the reference B (same particles)");
  compare_cmd->add_option("a", compare.a, "results file (.h5)")->required();
  compare_cmd->add_option("b", compare.b, "reference results file (.h5)")->required();
  c.compare_step_opt =
      compare_cmd->add_option("--step", c.compare_step, "step K of both files (default: the last of each)");
  c.compare_tol_opt =
      compare_cmd->add_option("--tol", c.compare_tol, "exit code 1 when the relative L2 difference exceeds T");
  compare_cmd->add_flag("--json", compare.json, "print one JSON object");
  compare_cmd->footer(
      "Example (ADR against Newton on the same scene):\n"
      "  peristat run cases/tension_plate/scene.yaml --out newton\n"
      "  peristat run cases/tension_plate/scene.yaml --out adr --solver adr\n"
      "  peristat compare adr/tension_plate.h5 newton/tension_plate.h5 --tol 1e-6");
}

/// Runs the subcommand the parsed command line names; its exit code.
int run_subcommand(CommandLine& c) {
  if (*c.run_cmd) return run_command(c.run);
  if (*c.check_cmd) return check_command(c.check_scene, c.check_overrides);
  if (*c.probe_cmd) {
    c.probe.x0 = c.line[0];
    c.probe.y0 = c.line[1];
    c.probe.x1 = c.line[2];
    c.probe.y1 = c.line[3];
    return probe_command(c.probe);
  }
  if (*c.compare_cmd) {
    if (c.compare_step_opt->count() > 0) c.compare.step = c.compare_step;
    if (c.compare_tol_opt->count() > 0) c.compare.tol = c.compare_tol;
    return compare_command(c.compare);
  }
  return exit_internal_error;
}

}  // namespace
}  // namespace peristat

int main(int argc, char** argv) {
  using namespace peristat;
  // Under mpirun: MPI starts now, and the ranks other than 0 print nothing (they run the same
  // model; docs/guide/distributed.md).
  return_large_blocks();  // before anything is allocated: freed arrays leave no holes (huge_pages.hpp)
  const parallel::Session mpi;
  register_linear_solvers();  // belos and the bond_amg V-cycle behind the linear-solver seam
  silence_other_ranks();
  CLI::App app{"peristat: quasi-static state-based peridynamics (Newton on a consistent tangent)"};
  app.require_subcommand(1);
  app.set_version_flag("--version", program_description(), "print peristat's version and commit, and exit");
  CommandLine command_line;
  add_run_command(app, command_line);
  add_other_commands(app, command_line);
  app.footer(
      "Example:\n  peristat run cases/tension_plate/scene.yaml --out out\n"
      "Each subcommand's --help gives its options and an example; docs/guide/tutorial.md builds a scene from "
      "an empty file.");

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? exit_success : exit_bad_input;
  }

  try {
    return run_subcommand(command_line);
  } catch (const InputError& e) {
    std::fprintf(stderr, "peristat: error: %s\n", e.what());
    return exit_bad_input;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "peristat: internal error: %s\n", e.what());
    std::fflush(stderr);
    parallel::abort_if_distributed(exit_internal_error);
    return exit_internal_error;
  }
}
