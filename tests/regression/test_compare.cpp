// `peristat compare` end to end: measures, --tol exit codes, --json, --step and the
// bad-input exits. The runs are the tension plate in smoke mode (dx = 5 mm, 400 real
// particles, small kinematics so the displacement is linear in the boundary value), about
// 0.3 s each; a test makes at most two.
#include <cmath>
#include <filesystem>
#include <map>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "io/results.hpp"
#include "support/cli.hpp"

namespace peristat {
namespace {

namespace fs = std::filesystem;

const std::string kTension = std::string(PERISTAT_SOURCE_DIR) + "/cases/tension_plate/scene.yaml";
const std::string kSmoke =
    " --quiet --set discretization.spacing=5e-3 --set materials.aluminium.kinematics=small";

/// The JSON object of `compare --json` (a discarded value if the text is not JSON).
nlohmann::json parse(const std::string& text) {
  return nlohmann::json::parse(text, nullptr, false);
}

using test::json_number;

bool contains(const std::string& text, const std::string& what) {
  return text.find(what) != std::string::npos;
}

/// The runs, made on first use and shared by the tests of one process (ctest runs each
/// test in its own process, so a test makes only the runs it needs).
class CompareCli : public ::testing::Test {
 protected:
  static void TearDownTestSuite() {
    if (!s_dir.empty()) fs::remove_all(s_dir);
    s_dir.clear();
    s_runs.clear();
  }

  static const std::string& plain() { return run("plain", ""); }
  static const std::string& again() { return run("again", ""); }
  /// The right edge's ux, 1.0e-4 in the scene, times 1.01.
  static const std::string& scaled() { return run("scaled", " --set boundary.1.ux=1.01e-4"); }
  static const std::string& coarser() { return run("coarser", " --set discretization.spacing=4e-3"); }
  static const std::string& one_step() { return run("one_step", " --set loading.steps=1"); }
  static const fs::path& dir() {
    if (s_dir.empty()) s_dir = test::fresh_directory("compare_cli");
    return s_dir;
  }

 private:
  /// Runs the plate with `extra` into DIR/<name> once; returns DIR/<name>/tension_plate.h5.
  static const std::string& run(const std::string& name, const std::string& extra) {
    auto [it, inserted] = s_runs.try_emplace(name);
    if (inserted) {
      const fs::path out = dir() / name;
      const auto r = test::run_cli("run " + kTension + " --out " + out.string() + kSmoke + extra);
      EXPECT_EQ(r.exit_code, 0) << name << ": " << r.out << r.err;
      it->second = (out / "tension_plate.h5").string();
    }
    return it->second;
  }

  static inline fs::path s_dir;
  static inline std::map<std::string, std::string> s_runs;
};

// A is the plain run, B (the reference) the one with the boundary displacement times 1.01:
// uA = uB / 1.01 exactly in small kinematics, so |uA - uB| / |uB| = 1 - 1/1.01 for the
// whole field and for the largest particle displacement alike. Tolerance 1e-8: the solves
// stop at a relative residual of 1e-10.
TEST_F(CompareCli, ScaledBoundaryDisplacementGivesTheScaleDifference) {
  const double expected = 1.0 - 1.0 / 1.01;
  const auto r = test::run_cli("compare " + plain() + " " + scaled() + " --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NEAR(json_number(r.out, "relative_l2"), expected, 1e-8) << r.out;
  EXPECT_NEAR(json_number(r.out, "max_relative"), expected, 1e-8) << r.out;
  EXPECT_EQ(json_number(r.out, "particles"), 400.0) << r.out;  // 20 x 20 real particles
  EXPECT_EQ(json_number(r.out, "step_a"), 2.0);
  EXPECT_EQ(json_number(r.out, "load_factor"), 1.0);
  const nlohmann::json json = parse(r.out);
  EXPECT_TRUE(json.contains("bodies") && json["bodies"].contains("plate")) << r.out;
  EXPECT_TRUE(json.contains("tol") && json["tol"].is_null()) << r.out;
  EXPECT_TRUE(json.contains("within_tol") && json["within_tol"].is_null()) << r.out;

  const auto text = test::run_cli("compare " + plain() + " " + scaled());
  ASSERT_EQ(text.exit_code, 0) << text.err;
  EXPECT_TRUE(contains(text.out, "(step 2, load factor 1) against ")) << text.out;
  EXPECT_TRUE(contains(text.out, ": 400 real particles\n")) << text.out;
  EXPECT_TRUE(contains(text.out, "all         relative L2 9.9010e-03")) << text.out;
  EXPECT_TRUE(contains(text.out, "body plate  relative L2 9.9010e-03")) << text.out;
}

// Two runs of the same scene: the same solve, so at most rounding differences (the
// threaded assembly may sum in another order); a file against itself gives exactly 0.
TEST_F(CompareCli, IdenticalRunsGiveZero) {
  const auto r = test::run_cli("compare " + again() + " " + plain() + " --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_LE(json_number(r.out, "relative_l2"), 1e-12) << r.out;
  const auto self = test::run_cli("compare " + plain() + " " + plain() + " --tol 1e-12");
  EXPECT_EQ(self.exit_code, 0) << self.err;
  EXPECT_TRUE(contains(self.out, "all         relative L2 0.0000e+00")) << self.out;
  EXPECT_TRUE(contains(self.out, "is within --tol 1e-12")) << self.out;
}

// The difference is 9.9e-3: --tol 0.02 passes (exit 0), --tol 0.005 fails (exit 1).
TEST_F(CompareCli, TolDecidesTheExitCode) {
  const auto pass = test::run_cli("compare " + plain() + " " + scaled() + " --tol 0.02");
  EXPECT_EQ(pass.exit_code, 0) << pass.out << pass.err;
  EXPECT_TRUE(contains(pass.out, "relative L2 9.9010e-03 is within --tol 0.02")) << pass.out;

  const auto fail = test::run_cli("compare " + plain() + " " + scaled() + " --tol 0.005");
  EXPECT_EQ(fail.exit_code, 1) << fail.out << fail.err;
  EXPECT_TRUE(contains(fail.out, "relative L2 9.9010e-03 exceeds --tol 0.005")) << fail.out;

  // With --json the verdict goes to stderr and stdout holds the JSON object alone.
  const auto json = test::run_cli("compare " + plain() + " " + scaled() + " --tol 0.005 --json");
  EXPECT_EQ(json.exit_code, 1);
  const nlohmann::json verdict = parse(json.out);
  EXPECT_TRUE(verdict.contains("within_tol") && verdict["within_tol"] == false) << json.out;
  EXPECT_EQ(json.out.front(), '{');
  EXPECT_TRUE(contains(json.err, "exceeds --tol 0.005")) << json.err;

  const auto bad = test::run_cli("compare " + plain() + " " + scaled() + " --tol 0");
  EXPECT_EQ(bad.exit_code, 2);
  EXPECT_TRUE(contains(bad.err, "--tol: expected a positive number, got 0")) << bad.err;
}

TEST_F(CompareCli, DifferentSpacingIsBadInput) {
  const auto r = test::run_cli("compare " + plain() + " " + coarser());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_TRUE(r.out.empty()) << r.out;
  EXPECT_TRUE(contains(r.err, plain() + " and " + coarser() + " do not hold the same particles")) << r.err;
  // All particles, the mirror grips' 2 x 8 layers included: 400 + 320 and 625 + 400.
  EXPECT_TRUE(contains(r.err, plain() + " has 720 particles, " + coarser() + " has 1025")) << r.err;
}

TEST_F(CompareCli, MissingOrForeignFileIsBadInput) {
  const std::string missing = (dir() / "nothing.h5").string();
  const auto r = test::run_cli("compare " + plain() + " " + missing);
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_TRUE(contains(r.err, "'" + missing + "' does not exist")) << r.err;

  const auto scene = test::run_cli("compare " + kTension + " " + plain());
  EXPECT_EQ(scene.exit_code, 2);
  EXPECT_TRUE(contains(scene.err, kTension + "' is not an HDF5 file")) << scene.err;
}

TEST_F(CompareCli, StepBeyondTheLastIsBadInput) {
  const auto r = test::run_cli("compare " + plain() + " " + plain() + " --step 3");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_TRUE(contains(r.err, plain() + ": --step 3 is not in the file (steps 1 to 2)")) << r.err;
  // The 1-step run lacks step 2: the message names that file.
  const auto second = test::run_cli("compare " + plain() + " " + one_step() + " --step 2");
  EXPECT_EQ(second.exit_code, 2);
  EXPECT_TRUE(contains(second.err, one_step() + ": --step 2 is not in the file (steps 1 to 1)"))
      << second.err;
}

// Step 1 of the 2-step run is at load factor 0.5, step 1 of the 1-step run at 1. An explicit
// --step compares them anyway with a warning (uA = uB / 2: relative L2 0.5).
TEST_F(CompareCli, ExplicitStepAtDifferentLoadFactorsWarns) {
  const auto r = test::run_cli("compare " + plain() + " " + one_step() + " --step 1 --json");
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_TRUE(
      contains(r.err, "warning: step 1 is at load factor 0.5 in " + plain() + " and 1 in " + one_step()))
      << r.err;
  EXPECT_NEAR(json_number(r.out, "relative_l2"), 0.5, 1e-8) << r.out;
  EXPECT_EQ(json_number(r.out, "load_factor_a"), 0.5);
  EXPECT_EQ(json_number(r.out, "load_factor_b"), 1.0);

  // By default the last steps are compared: both at load factor 1, no warning.
  const auto last = test::run_cli("compare " + plain() + " " + one_step());
  EXPECT_EQ(last.exit_code, 0) << last.err;
  EXPECT_TRUE(last.err.empty()) << last.err;
  EXPECT_TRUE(
      contains(last.out, "(step 2, load factor 1) against " + one_step() + " (step 1, load factor 1)"))
      << last.out;
}

// A run stopped after its first step ends at load factor 0.5. Made here by writing step 1
// of the plain run alone into a new file with the same particles.
TEST_F(CompareCli, LastStepsAtDifferentLoadFactorsAreBadInput) {
  const ResultsReader reader(plain());
  const VectorXd u = reader.displacement(1);
  const fs::path stopped_dir = dir() / "stopped";
  std::string stopped;
  {
    ResultsWriter writer(stopped_dir.string(), "tension_plate", reader.scene_text(), reader.particles(),
                         "{}");
    StepRecord step;
    step.index = 1;
    step.load_factor = reader.load_factor(1);
    step.displacement = &u;
    writer.write_step(step);
    writer.finish("interrupted", "stopped after step 1");
    stopped = writer.h5_path();
  }
  const auto r = test::run_cli("compare " + stopped + " " + plain());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_TRUE(contains(r.err, stopped + " ends at load factor 0.5, " + plain() + " at 1: choose --step K"))
      << r.err;

  const auto step1 = test::run_cli("compare " + stopped + " " + plain() + " --step 1 --json");
  EXPECT_EQ(step1.exit_code, 0) << step1.err;
  EXPECT_EQ(json_number(step1.out, "relative_l2"), 0.0) << step1.out;
}

}  // namespace
}  // namespace peristat
