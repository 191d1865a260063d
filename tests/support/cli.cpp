#include "support/cli.hpp"

#include <atomic>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <random>
#include <sstream>
#include <sys/wait.h>
#include <unistd.h>

namespace peristat::test {

std::filesystem::path fresh_directory(const std::string& stem) {
  static std::atomic<int> counter{0};
  const auto dir = std::filesystem::temp_directory_path() /
                   ("peristat_" + stem + "_" + std::to_string(::getpid()) + "_" + std::to_string(counter++));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

std::string read_file(const std::filesystem::path& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

nlohmann::json read_json(const std::filesystem::path& path) {
  return nlohmann::json::parse(read_file(path), nullptr, false);
}

namespace {
/// The number at `key` of a JSON object, or NaN.
double number_at(const nlohmann::json& object, const std::string& key) {
  if (!object.is_object()) return std::nan("");
  const auto it = object.find(key);
  return it != object.end() && it->is_number() ? it->get<double>() : std::nan("");
}
}  // namespace

double json_number(const std::string& text, const std::string& key) {
  return number_at(nlohmann::json::parse(text, nullptr, false), key);
}

double step_number(const std::string& summary, int step, const std::string& key) {
  const nlohmann::json doc = nlohmann::json::parse(summary, nullptr, false);
  if (!doc.is_object() || !doc.contains("steps")) return std::nan("");
  for (const nlohmann::json& s : doc["steps"]) {
    if (s.value("step", -1) != step) continue;
    const double direct = number_at(s, key);
    return std::isnan(direct) && s.contains("counts") ? number_at(s["counts"], key) : direct;
  }
  return std::nan("");
}

CliResult run_command(const std::string& command) {
  const auto dir = fresh_directory("cli");
  const auto out = dir / "stdout", err = dir / "stderr";
  const std::string cmd = command + " > " + out.string() + " 2> " + err.string();
  const int status = std::system(cmd.c_str());
  CliResult r;
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  r.out = read_file(out);
  r.err = read_file(err);
  std::filesystem::remove_all(dir);
  return r;
}

CliResult run_cli(const std::string& arguments) { return run_command(std::string(PERISTAT_EXE) + " " + arguments); }

CliResult run_mpi(int ranks, const std::string& arguments) {
  return run_command("OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 " + std::string(PERISTAT_MPIEXEC) +
                     " --oversubscribe -n " + std::to_string(ranks) + " " + PERISTAT_EXE + " " + arguments);
}

}  // namespace peristat::test
