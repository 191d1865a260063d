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

double json_number(const std::string& text, const std::string& key) {
  const std::string pattern = "\"" + key + "\": ";
  const auto at = text.find(pattern);
  if (at == std::string::npos) return std::nan("");
  return std::strtod(text.c_str() + at + pattern.size(), nullptr);
}

double step_number(const std::string& summary, int step, const std::string& key) {
  const std::string marker = "\"step\": ";
  const auto at = summary.find(marker + std::to_string(step) + ",");
  if (at == std::string::npos) return std::nan("");
  const auto next = summary.find(marker, at + marker.size());  // the next step's object
  return json_number(summary.substr(at, next == std::string::npos ? std::string::npos : next - at), key);
}

CliResult run_cli(const std::string& arguments) {
  const auto dir = fresh_directory("cli");
  const auto out = dir / "stdout", err = dir / "stderr";
  const std::string cmd =
      std::string(PERISTAT_EXE) + " " + arguments + " > " + out.string() + " 2> " + err.string();
  const int status = std::system(cmd.c_str());
  CliResult r;
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  r.out = read_file(out);
  r.err = read_file(err);
  std::filesystem::remove_all(dir);
  return r;
}

}  // namespace peristat::test
