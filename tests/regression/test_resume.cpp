// peristat run --resume after SIGKILL (issue 15, part 5): case 4.4 (contact, friction, bond
// failure) at a coarse spacing is killed at three moments (early in a step, late in a step, and
// inside the write of a step's results) and resumed; the final answer equals the uninterrupted
// run's to 1e-10. A resume with other options is refused and says which.
#include <chrono>
#include <csignal>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <sys/wait.h>
#include <thread>
#include <unistd.h>

#include <gtest/gtest.h>
#include <spawn.h>

#include "support/cli.hpp"
#include "support/scenes.hpp"

extern char** environ;

namespace peristat {
namespace {

namespace fs = std::filesystem;

const std::string kScene = std::string(PERISTAT_SOURCE_DIR) + "/cases/paper_4_4_crack_growth/scene.yaml";
// 16.8 s on one thread (2026-11-25): steps 1-4 take 3.3 s, steps 5 and 6 break 390 bonds.
const std::string kOptions = " --quiet --threads 1 --set discretization.spacing=0.04";

int converged_steps(const fs::path& dir) {
  const nlohmann::json s = test::read_json(dir / "summary.json");
  return s.is_object() && s.contains("steps") ? static_cast<int>(s["steps"].size()) : 0;
}

/// Starts the run in `dir`, waits until `steps` load steps are in its summary, waits `extra`
/// more and kills it with SIGKILL. Returns the wait status (the run must not have finished).
int run_and_kill(const fs::path& dir, int steps, std::chrono::milliseconds extra) {
  const std::string exe = PERISTAT_EXE;
  std::vector<std::string> args = {exe, "run", kScene, "--out", dir.string(), "--quiet", "--threads", "1",
                                   "--set", "discretization.spacing=0.04"};
  std::vector<char*> argv;
  for (std::string& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  pid_t pid = 0;
  if (posix_spawn(&pid, exe.c_str(), nullptr, nullptr, argv.data(), environ) != 0) return -1;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(120);
  int status = 0;
  while (converged_steps(dir) < steps && std::chrono::steady_clock::now() < deadline) {
    if (waitpid(pid, &status, WNOHANG) == pid) return status;  // finished before the kill
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  std::this_thread::sleep_for(extra);
  kill(pid, SIGKILL);
  waitpid(pid, &status, 0);
  return status;
}

/// Relative L2 difference of the last steps of two results files (peristat compare --json).
double difference(const fs::path& a, const fs::path& b) {
  const test::CliResult r = test::run_cli("compare " + (a / "paper_4_4_crack_growth.h5").string() + " " +
                                          (b / "paper_4_4_crack_growth.h5").string() + " --json");
  EXPECT_EQ(r.exit_code, 0) << r.err;
  return test::json_number(r.out, "relative_l2");
}

/// Resumes the killed run in `dir` until it completes and compares it with the reference.
void resume_and_compare(const fs::path& dir, const fs::path& reference) {
  const test::CliResult r = test::run_cli("run " + kScene + " --out " + dir.string() + kOptions + " --resume");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const nlohmann::json s = test::read_json(dir / "summary.json");
  EXPECT_EQ(s.value("status", ""), "completed");
  EXPECT_EQ(converged_steps(dir), 6) << "every step once, none lost or repeated";
  // 1e-10 (issue 15); measured 3.5e-17 at the default spacing (round-off of a different
  // summation order in the first evaluations after the resume).
  EXPECT_LT(difference(dir, reference), 1e-10);
}

// One test, so that the uninterrupted reference (17 s) runs once.
TEST(Resume, ThreeKillsEqualTheUninterruptedRun) {
  const fs::path reference = test::fresh_directory("resume_reference");
  const test::CliResult r = test::run_cli("run " + kScene + " --out " + reference.string() + kOptions);
  ASSERT_EQ(r.exit_code, 0) << r.err;

  // Early in step 3 (50 ms after step 2 was written).
  const fs::path early = test::fresh_directory("resume_early");
  int status = run_and_kill(early, 2, std::chrono::milliseconds(50));
  ASSERT_TRUE(WIFSIGNALED(status) && WTERMSIG(status) == SIGKILL) << "the run ended before the kill";
  EXPECT_EQ(converged_steps(early), 2) << "killed in step 3";
  resume_and_compare(early, reference);

  // While step 5 breaks bonds: halfway through the reference's step 5 after step 4 was
  // written (a fixed delay ran past the end of the run once the solver got faster: steps 5
  // and 6 took 2.3 s against a kill at 2.5 s).
  const nlohmann::json steps = test::read_json(reference / "summary.json")["steps"];
  ASSERT_EQ(steps.size(), 6u);
  const double step5 = steps[4].value("wall_seconds", 0.0);
  ASSERT_GT(step5, 0.0);
  ASSERT_GT(steps[4]["counts"].value("bonds_broken", 0), 0) << "step 5 must break bonds";
  const fs::path breaking = test::fresh_directory("resume_breaking");
  status = run_and_kill(breaking, 4, std::chrono::milliseconds(static_cast<long>(500.0 * step5)));
  ASSERT_TRUE(WIFSIGNALED(status) && WTERMSIG(status) == SIGKILL) << "the run ended before the kill";
  EXPECT_EQ(converged_steps(breaking), 4) << "killed in step 5";
  resume_and_compare(breaking, reference);

  // Inside the write of step 3's results (fault injection: the group is in the copy of the
  // file, not yet renamed over it): the file keeps steps 1 and 2 and stays readable.
  const fs::path in_write = test::fresh_directory("resume_in_write");
  status = std::system(("PERISTAT_FAULT_KILL_IN_WRITE=3 " + std::string(PERISTAT_EXE) + " run " + kScene +
                        " --out " + in_write.string() + kOptions + " > /dev/null 2>&1")
                           .c_str());
  ASSERT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 128 + SIGKILL) << "status " << status;
  EXPECT_EQ(converged_steps(in_write), 2);
  const test::CliResult probe =
      test::run_cli("probe " + (in_write / "paper_4_4_crack_growth.h5").string() + " --line 0 0 0.1 0.1 --points 3");
  EXPECT_EQ(probe.exit_code, 0) << "the file is readable after a kill inside a write: " << probe.err;
  resume_and_compare(in_write, reference);

  for (const fs::path& dir : {reference, early, breaking, in_write}) fs::remove_all(dir);
}

TEST(Resume, OtherOptionsAreRefused) {
  const std::string tension = std::string(PERISTAT_SOURCE_DIR) + "/cases/tension_plate/scene.yaml";
  const fs::path dir = test::fresh_directory("resume_refused");
  const std::string common = "run " + tension + " --out " + dir.string() + " --quiet";
  ASSERT_EQ(test::run_cli(common + " --set discretization.spacing=4e-3").exit_code, 0);
  const test::CliResult other = test::run_cli(common + " --set discretization.spacing=5e-3 --resume");
  EXPECT_EQ(other.exit_code, 2);
  EXPECT_NE(other.err.find("--set options [discretization.spacing=4e-3]"), std::string::npos) << other.err;
  const fs::path empty = test::fresh_directory("resume_nothing");
  const test::CliResult none = test::run_cli("run " + tension + " --out " + empty.string() + " --quiet --resume");
  EXPECT_EQ(none.exit_code, 2);
  EXPECT_NE(none.err.find("no checkpoint"), std::string::npos) << none.err;
  for (const fs::path& d : {dir, empty}) fs::remove_all(d);
}

// The first load step of a run from the unloaded state stops its last Krylov solve as soon as
// the tolerance allows (docs/theory/newton.md, "Inexact Newton"); the checkpoint then holds
// that state, and the resumed run's later steps must still end where the uninterrupted run's
// do. The tension plate stretched to 3 % in three steps (matrix_free), whose step 1 takes
// 92 Krylov iterations instead of 99 that way, killed inside the write of step 2's results.
TEST(Resume, AfterTheFirstStepsLooseLastSolve) {
  const fs::path dir = test::fresh_directory("resume_loose_first_step");
  const fs::path scene = dir / "plate.yaml";
  std::ofstream(scene) << test::stretched_tension_plate("3.0e-3", 3);
  const std::string options = " --quiet --threads 1";
  const fs::path reference = dir / "reference", killed = dir / "killed";
  test::CliResult r = test::run_cli("run " + scene.string() + " --out " + reference.string() + options);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const int status =
      std::system(("PERISTAT_FAULT_KILL_IN_WRITE=2 " + std::string(PERISTAT_EXE) + " run " + scene.string() +
                   " --out " + killed.string() + options + " > /dev/null 2>&1")
                      .c_str());
  ASSERT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 128 + SIGKILL) << "status " << status;
  ASSERT_EQ(converged_steps(killed), 1);
  r = test::run_cli("run " + scene.string() + " --out " + killed.string() + options + " --resume");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(converged_steps(killed), 3);
  const test::CliResult cmp = test::run_cli("compare " + (killed / "tension_plate.h5").string() + " " +
                                            (reference / "tension_plate.h5").string() + " --json");
  ASSERT_EQ(cmp.exit_code, 0) << cmp.err;
  // 1e-10 (issue 15). Measured 1.1e-11, as with step 1 capped too: the resumed step 2 starts
  // from the Euler predictor, not the secant, and both end inside Newton's tolerance (final
  // residuals 3e-11 and 2e-12 of the force scale).
  EXPECT_LT(test::json_number(cmp.out, "relative_l2"), 1e-10);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace peristat
