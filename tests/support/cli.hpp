// Running the peristat program from tests.
#pragma once

#include <filesystem>
#include <string>

namespace peristat::test {

struct CliResult {
  int exit_code = -1;
  std::string out, err;
};

/// Runs PERISTAT_EXE with the arguments (a shell-quoted string) and captures both streams.
CliResult run_cli(const std::string& arguments);

/// A fresh empty directory under the system temporary directory.
std::filesystem::path fresh_directory(const std::string& stem);

std::string read_file(const std::filesystem::path& path);

/// The number after the first `"key": ` in JSON text (e.g. summary.json or compare --json),
/// or NaN when the key is absent.
double json_number(const std::string& text, const std::string& key);

/// The number `key` of load step `step` in a summary.json text (a field of the step or of its
/// "counts", e.g. "contact_stick", "broken_bonds_total"), or NaN when the step lacks it.
double step_number(const std::string& summary, int step, const std::string& key);

}  // namespace peristat::test
