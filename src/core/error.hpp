// The two tiers of error: input errors (always checked, exit code 2) and internal
// invariants (PERISTAT_ASSERT, debug builds). Non-convergence is not an exception:
// solvers return a report (SolveReport, solvers/step_solver.hpp).
#pragma once

#include <cassert>
#include <stdexcept>
#include <string>

namespace peristat {

/// Process exit codes, as README.md lists them ("Using it"); an interrupted run exits with
/// 128 + the signal (src/app).
enum ExitCode : int {
  exit_success = 0,
  exit_internal_error = 1,
  exit_bad_input = 2,
  exit_no_convergence = 3,
};

/// Where in the input a value came from: the scene file and line, or a --set override.
struct SourceLocation {
  std::string file;  ///< scene path, or "--set" for a command-line override
  int line = 0;      ///< 1-based; 0 when unknown
  std::string key;   ///< dotted key path, e.g. "materials.steel.E"

  /// "scene.yaml:12: materials.steel.E" (line omitted when unknown).
  std::string describe() const {
    std::string s = file;
    if (line > 0) s.append(":").append(std::to_string(line));
    if (!key.empty()) {
      if (!s.empty()) s.append(": ");
      s.append(key);
    }
    return s;
  }
};

/// Bad input or usage: the message names file, line and key. Exit code 2.
class InputError : public std::runtime_error {
 public:
  explicit InputError(const std::string& message) : std::runtime_error(message) {}
  InputError(const SourceLocation& where, const std::string& message)
      : std::runtime_error(where.describe() + ": " + message) {}
};

/// The model cannot follow the state the run reached (e.g. a bond breaking inside a mirror
/// condition's reflected layers). The run stops with exit code 3 and this reason; converged
/// steps are kept.
class ModelLimit : public std::runtime_error {
 public:
  explicit ModelLimit(const std::string& message) : std::runtime_error(message) {}
};

}  // namespace peristat

#ifndef NDEBUG
#define PERISTAT_ASSERT(cond) assert(cond)
#else
#define PERISTAT_ASSERT(cond) ((void)0)
#endif
