// The two tiers of error: input errors (always checked, exit code 2) and internal
// invariants (PERISTAT_ASSERT, debug builds). Non-convergence is not an exception:
// solvers return a report (SolveReport, solvers/step_solver.hpp).
#pragma once

#include <cassert>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace peristat {

/// Process exit codes, as docs/guide/scene.md lists them ("The command line"); an interrupted run exits with
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

/// On the ranks' parts: the contact faces slid past what the parts hold (a face particle has a
/// partner within the search radius that its rank does not hold). Thrown by every rank alike;
/// each carries the particles (global ids, ascending) its part must take in to follow the
/// faces. `peristat run` re-cuts the parts with them and solves the step again from the last
/// converged step (docs/guide/distributed.md, "Contact on the parts"); elsewhere it stops the
/// run like any ModelLimit.
class PartsOutgrown : public ModelLimit {
 public:
  PartsOutgrown(const std::string& message, std::vector<std::int64_t> particles, std::int64_t total)
      : ModelLimit(message), m_particles(std::move(particles)), m_total(total) {}
  /// This rank's particles to take in, by global id.
  const std::vector<std::int64_t>& particles() const { return m_particles; }
  /// Their count summed over the ranks.
  std::int64_t total() const { return m_total; }

 private:
  std::vector<std::int64_t> m_particles;
  std::int64_t m_total = 0;
};

}  // namespace peristat

#ifndef NDEBUG
#define PERISTAT_ASSERT(cond) assert(cond)
#else
#define PERISTAT_ASSERT(cond) ((void)0)
#endif
