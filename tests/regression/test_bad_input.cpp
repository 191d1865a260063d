// End to end: `peristat run` on bad input prints one "peristat: error: FILE:LINE: KEY: ..."
// line on stderr, exits with status 2 and writes no results.
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <sys/wait.h>

#include <gtest/gtest.h>

namespace {

namespace fs = std::filesystem;

// The minimal valid scene; the tests edit one line and assert on line numbers (1-based,
// given in the comments).
const std::string k_minimal =
    "name: minimal\n"                                    // 1
    "materials:\n"                                       // 2
    "  plate:\n"                                         // 3
    "    E: 1.0e9\n"                                     // 4
    "    nu: 0.3\n"                                      // 5
    "    thickness: 1.0e-3\n"                            // 6
    "discretization:\n"                                  // 7
    "  spacing: 1.0e-3\n"                                // 8
    "bodies:\n"                                          // 9
    "  plate:\n"                                         // 10
    "    material: plate\n"                              // 11
    "    rectangle: {min: [0, 0], max: [0.02, 0.01]}\n"  // 12
    "boundary:\n"                                        // 13
    "  - body: plate\n"                                  // 14
    "    edge: left\n"                                   // 15
    "    ux: 0\n"                                        // 16
    "    uy: 0\n"                                        // 17
    "  - body: plate\n"                                  // 18
    "    edge: right\n"                                  // 19
    "    ux: 1.0e-5\n";                                  // 20

std::string replace(std::string text, const std::string& from, const std::string& to) {
  const auto at = text.find(from);
  EXPECT_NE(at, std::string::npos) << "test bug: \"" << from << "\" not in the scene";
  if (at != std::string::npos) text.replace(at, from.size(), to);
  return text;
}

struct Outcome {
  int exit_status = -1;  ///< -1 if the program did not exit normally
  std::string stderr_text;
};

class BadInput : public ::testing::Test {
 protected:
  void SetUp() override {
    std::string pattern = (fs::temp_directory_path() / "peristat_bad_input_XXXXXX").string();
    ASSERT_NE(mkdtemp(pattern.data()), nullptr);
    m_dir = pattern;
  }
  void TearDown() override { fs::remove_all(m_dir); }

  std::string scene_path() const { return (m_dir / "scene.yaml").string(); }
  fs::path out_dir() const { return m_dir / "out"; }

  /// Runs `peristat run SCENE --out DIR/out EXTRA` on `text` written to DIR/scene.yaml.
  Outcome run_text(const std::string& text, const std::string& extra = "") {
    std::ofstream(scene_path()) << text;
    return run(scene_path(), extra);
  }

  Outcome run(const std::string& scene, const std::string& extra) {
    const fs::path err = m_dir / "stderr.txt";
    const std::string command = "'" PERISTAT_EXE "' run '" + scene + "' --out '" + out_dir().string() + "' " +
                                extra + " > /dev/null 2> '" + err.string() + "'";
    const int status = std::system(command.c_str());
    Outcome o;
    if (status != -1 && WIFEXITED(status)) o.exit_status = WEXITSTATUS(status);
    std::ifstream in(err);
    std::ostringstream text;
    text << in.rdbuf();
    o.stderr_text = text.str();
    return o;
  }

  /// Exit status 2, "peristat: error: " followed by `where` on stderr, the message
  /// mentions `what`, and nothing was written under the output directory.
  void expect_rejected(const Outcome& o, const std::string& where, const std::string& what) {
    EXPECT_EQ(o.exit_status, 2) << "stderr: " << o.stderr_text;
    EXPECT_NE(o.stderr_text.find("peristat: error: " + where), std::string::npos)
        << "stderr: " << o.stderr_text << "\nexpected: peristat: error: " << where;
    EXPECT_NE(o.stderr_text.find(what), std::string::npos)
        << "stderr: " << o.stderr_text << "\nexpected: " << what;
    expect_no_results();
  }

  void expect_no_results() const {
    if (!fs::exists(out_dir())) return;
    for (const auto& entry : fs::recursive_directory_iterator(out_dir()))
      EXPECT_FALSE(entry.is_regular_file()) << "results written on bad input: " << entry.path();
  }

  /// "DIR/scene.yaml:LINE: KEY"
  std::string at(int line, const std::string& key) const {
    return scene_path() + ":" + std::to_string(line) + ": " + key;
  }

 private:
  fs::path m_dir;
};

TEST_F(BadInput, UnknownKey) {
  expect_rejected(run_text(k_minimal + "fracture:\n  enabled: true\n"), at(21, "fracture"),
                  "unknown key \"fracture\"");
}

// A contact interface between bodies that do not touch: found only when the candidates are
// built (after parsing), still exit code 2 naming the interface's line.
TEST_F(BadInput, ContactInterfaceWithoutCommonEdge) {
  const std::string text = replace(k_minimal, "    rectangle: {min: [0, 0], max: [0.02, 0.01]}\n",
                                   "    rectangle: {min: [0, 0], max: [0.02, 0.01]}\n"
                                   "  other:\n"
                                   "    material: plate\n"
                                   "    rectangle: {min: [0.03, 0], max: [0.05, 0.01]}\n") +
                           "  - {body: other, edge: left, ux: 0, uy: 0}\n"
                           "contact:\n"
                           "  interfaces:\n"
                           "    - {bodies: [plate, other]}\n";
  expect_rejected(run_text(text), at(27, "contact.interfaces.0"), "share no boundary segment");
}

// Exact enforcement acts on the gap along the interface normal, which the pair law lacks;
// the closure tolerance is a fraction in (0, 1).
TEST_F(BadInput, ExactContactNeedsThePaperNormalLaw) {
  expect_rejected(run_text(k_minimal + "contact:\n  normal: pair\n  enforcement: exact\n"),
                  at(23, "contact.enforcement"), "needs normal: paper");
}

TEST_F(BadInput, ClosureToleranceOutOfRange) {
  expect_rejected(run_text(k_minimal + "contact:\n  enforcement: exact\n  closure_tolerance: 0\n"),
                  at(23, "contact.closure_tolerance"), "0 < closure_tolerance < 1");
  expect_rejected(run_text(k_minimal + "contact:\n  enforcement: exact\n  closure_tolerance: 1.5\n"),
                  at(23, "contact.closure_tolerance"), "0 < closure_tolerance < 1");
  expect_rejected(run_text(k_minimal + "contact:\n  enforcement: penalty\n  friction: 0.3\n  stick: exact\n"),
                  at(24, "contact.stick"), "stick: exact needs enforcement: exact");
}

TEST_F(BadInput, UnknownEnforcement) {
  expect_rejected(run_text(k_minimal + "contact:\n  enforcement: lagrange\n"), at(22, "contact.enforcement"),
                  "penalty");
}

TEST_F(BadInput, WrongType) {
  expect_rejected(run_text(replace(k_minimal, "E: 1.0e9", "E: stiff")), at(4, "materials.plate.E"),
                  "expected a number");
}

TEST_F(BadInput, MissingRequiredKey) {
  expect_rejected(run_text(replace(k_minimal, "    thickness: 1.0e-3\n", "")),
                  at(3, "materials.plate.thickness"), "missing required key");
}

TEST_F(BadInput, YoungsModulusNotPositive) {
  expect_rejected(run_text(replace(k_minimal, "E: 1.0e9", "E: 0")), at(4, "materials.plate.E"),
                  "out of range");
  expect_rejected(run_text(replace(k_minimal, "E: 1.0e9", "E: -1.0e9")), at(4, "materials.plate.E"),
                  "out of range");
}

TEST_F(BadInput, PoissonRatioOutOfRange) {
  expect_rejected(run_text(replace(k_minimal, "nu: 0.3", "nu: 0.5")), at(5, "materials.plate.nu"),
                  "expected -1 < nu < 0.5");
  expect_rejected(run_text(replace(k_minimal, "nu: 0.3", "nu: -1")), at(5, "materials.plate.nu"),
                  "expected -1 < nu < 0.5");
}

TEST_F(BadInput, SpacingNotPositive) {
  expect_rejected(run_text(replace(k_minimal, "spacing: 1.0e-3", "spacing: 0")),
                  at(8, "discretization.spacing"), "out of range");
}

/// The minimal scene with `horizon_factor: m` on line 9.
std::string with_horizon_factor(const std::string& m) {
  return replace(k_minimal, "  spacing: 1.0e-3\n", "  spacing: 1.0e-3\n  horizon_factor: " + m + "\n");
}

TEST_F(BadInput, HorizonFactorBelowOne) {
  expect_rejected(run_text(with_horizon_factor("0.5")), at(9, "discretization.horizon_factor"),
                  "expected horizon_factor >= 1");
}

// Refused before anything is allocated (issue 15, "Refuse what cannot fit"; src/app/preflight.cpp).
// A spacing of 1e-7 m on the 20 x 10 mm plate is 2e10 particles, about 1e4 TB: exit 2 with the
// numbers, where it used to end in std::bad_alloc (exit 1).
TEST_F(BadInput, ModelThatCannotFitIsRefused) {
  const Outcome o = run_text(replace(k_minimal, "spacing: 1.0e-3", "spacing: 1.0e-7"));
  expect_rejected(o, at(8, "discretization.spacing"), "refused before allocating");
  EXPECT_NE(o.stderr_text.find("available"), std::string::npos) << o.stderr_text;
}

// A horizon factor of 1e6 (3e12 bonds per family) used to run for minutes without output.
TEST_F(BadInput, HugeFamilyIsRefused) {
  expect_rejected(run_text(with_horizon_factor("1.0e6")), at(9, "discretization.horizon_factor"),
                  "bonds per family; at most 2000 are accepted");
}

// A horizon longer than the body: every family spans it.
TEST_F(BadInput, HorizonLongerThanTheBodyIsRefused) {
  expect_rejected(run_text(with_horizon_factor("21")), at(9, "discretization.horizon_factor"),
                  "is longer than body 'plate'");
}

// horizon_factor 1 runs, with a warning on stderr and in summary.json that says what it costs.
TEST_F(BadInput, SmallHorizonFactorWarns) {
  const Outcome o = run_text(with_horizon_factor("1"), "--quiet");
  EXPECT_EQ(o.exit_status, 0) << o.stderr_text;
  EXPECT_NE(o.stderr_text.find("WARNING: " + at(9, "discretization.horizon_factor") + ": horizon_factor 1 < 2"),
            std::string::npos)
      << o.stderr_text;
  std::ifstream in(out_dir() / "summary.json");
  std::ostringstream text;
  text << in.rdbuf();
  EXPECT_NE(text.str().find("start a mode I crack at about 1.8 K_Ic"), std::string::npos);
}

TEST_F(BadInput, EmptyBodies) {
  const std::string head = k_minimal.substr(0, k_minimal.find("bodies:"));
  expect_rejected(run_text(head + "bodies: {}\n"), at(9, "bodies"), "at least one body");
}

TEST_F(BadInput, OverlappingBodies) {
  const std::string two = replace(k_minimal, "    rectangle: {min: [0, 0], max: [0.02, 0.01]}\n",
                                  "    rectangle: {min: [0, 0], max: [0.02, 0.01]}\n"  // 12
                                  "  other:\n"                                         // 13
                                  "    material: plate\n"                              // 14
                                  "    rectangle: {min: [0.01, 0], max: [0.03, 0.01]}\n");
  const Outcome o = run_text(two);
  EXPECT_EQ(o.exit_status, 2) << "stderr: " << o.stderr_text;
  // The discretisation may blame either body; it names the one it reports, at its line.
  const bool names_a_body =
      o.stderr_text.find("peristat: error: " + at(10, "bodies.plate")) != std::string::npos ||
      o.stderr_text.find("peristat: error: " + at(13, "bodies.other")) != std::string::npos;
  EXPECT_TRUE(names_a_body) << "stderr: " << o.stderr_text;
  EXPECT_NE(o.stderr_text.find("overlap"), std::string::npos) << "stderr: " << o.stderr_text;
  expect_no_results();
}

TEST_F(BadInput, ConditionSelectingNoParticle) {
  expect_rejected(
      run_text(replace(k_minimal, "    edge: right\n", "    region: {min: [1, 1], max: [2, 2]}\n")),
      at(18, "boundary.1"), "selects no particle");
}

TEST_F(BadInput, CrackOutsideEveryBody) {
  expect_rejected(run_text(k_minimal + "cracks:\n  - {from: [0.05, 0.05], to: [0.06, 0.06]}\n"),
                  at(22, "cracks.0"), "crack lies outside every body");
}

TEST_F(BadInput, DuplicateKey) {
  expect_rejected(run_text(replace(k_minimal, "    nu: 0.3\n", "    nu: 0.3\n    nu: 0.2\n")),
                  at(6, "materials.plate.nu"), "duplicate key");
}

TEST_F(BadInput, YamlSyntaxError) {
  expect_rejected(run_text(replace(k_minimal, "    nu: 0.3", "     nu: 0.3")), scene_path() + ":5",
                  "YAML syntax error");
}

TEST_F(BadInput, SetWithUnknownKey) {
  expect_rejected(run_text(k_minimal, "--set solver.lnear=umfpack"), "--set: solver.lnear",
                  "unknown key \"lnear\"");
}

TEST_F(BadInput, SetWithBadValue) {
  expect_rejected(run_text(k_minimal, "--set materials.plate.nu=0.7"), "--set: materials.plate.nu",
                  "out of range");
}

TEST_F(BadInput, SetWithoutEquals) {
  expect_rejected(run_text(k_minimal, "--set solver.linear"), "--set", "KEY=VALUE");
}

TEST_F(BadInput, MissingSceneFile) {
  const std::string missing = (out_dir().parent_path() / "missing.yaml").string();
  const Outcome o = run(missing, "");
  expect_rejected(o, missing, "missing.yaml");
}

}  // namespace
