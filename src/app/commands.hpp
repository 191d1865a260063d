// The peristat commands (docs/guide/scene.md, "The command line"). Each returns a process exit code; input
// errors propagate as InputError and are turned into exit code 2 by main().
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "scene/scene.hpp"

namespace peristat {

struct RunArguments {
  std::string scene;
  std::string out;                     ///< default: results/<scene name>
  std::string solver;                  ///< --solver, empty = from the scene
  std::vector<std::string> overrides;  ///< --set KEY=VALUE
  bool quiet = false;
  int threads = 0;  ///< 0 = OpenMP default
  bool resume = false;  ///< --resume: continue the run in `out` from its checkpoint
};

int run_command(const RunArguments& args);
int check_command(const std::string& scene_path, const std::vector<std::string>& overrides);

struct ProbeArguments {
  std::string results;
  double x0 = 0, y0 = 0, x1 = 0, y1 = 0;
  int step = -1;  ///< -1 = last step
  int points = 101;
};
int probe_command(const ProbeArguments& args);

struct CompareArguments {
  std::string a;              ///< results file compared
  std::string b;              ///< reference results file
  std::optional<int> step;    ///< --step K: step K of both; default the last step of each
  std::optional<double> tol;  ///< --tol T: exit code exit_tolerance_exceeded above T
  bool json = false;          ///< --json: one JSON object instead of text
};
/// `compare` exits with this code when the overall relative L2 difference exceeds --tol.
inline constexpr int exit_tolerance_exceeded = 1;
int compare_command(const CompareArguments& args);

}  // namespace peristat
