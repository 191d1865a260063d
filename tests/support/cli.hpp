// Running the peristat program from tests.
#pragma once

#include <filesystem>
#include <string>

#include <nlohmann/json.hpp>

namespace peristat::test {

struct CliResult {
  int exit_code = -1;
  std::string out, err;
};

/// Runs PERISTAT_EXE with the arguments (a shell-quoted string) and captures both streams.
CliResult run_cli(const std::string& arguments);

/// Runs a shell command line (e.g. `env ... PERISTAT_EXE ...`) and captures its streams.
CliResult run_command(const std::string& command);

/// Runs PERISTAT_EXE on `ranks` MPI ranks (mpirun from the MPI that CMake found; allowed as
/// root, and oversubscribed when the machine has fewer cores) and captures rank 0's streams
/// and mpirun's own.
CliResult run_mpi(int ranks, const std::string& arguments);

/// A fresh empty directory under the system temporary directory.
std::filesystem::path fresh_directory(const std::string& stem);

std::string read_file(const std::filesystem::path& path);

/// A JSON file such as summary.json, parsed (a discarded value if it is not JSON).
nlohmann::json read_json(const std::filesystem::path& path);

/// The number under `key` in the top-level object of JSON text (e.g. compare --json), or NaN
/// when the text is not JSON or the key is absent or not a number.
double json_number(const std::string& text, const std::string& key);

/// The number `key` of load step `step` in a summary.json text (a field of the step or of its
/// "counts", e.g. "contact_stick", "broken_bonds_total"), or NaN when the step lacks it.
double step_number(const std::string& summary, int step, const std::string& key);

}  // namespace peristat::test
