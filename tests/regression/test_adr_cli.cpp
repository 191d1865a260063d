// `peristat run --solver adr` end to end: progress, summary.json, and the two budget policies.
#include <algorithm>

#include <gtest/gtest.h>

#include "support/cli.hpp"

namespace peristat {
namespace {

const std::string kTension = std::string(PERISTAT_SOURCE_DIR) + "/cases/tension_plate/scene.yaml";
const std::string kSmoke = " --set discretization.spacing=4e-3";

TEST(AdrCli, RunsAndReportsIterations) {
  const auto dir = test::fresh_directory("adr_run");
  const auto r = test::run_cli("run " + kTension + " --solver adr --out " + dir.string() + kSmoke);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("ADR: rtol 1.0e-08"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("converged: "), std::string::npos) << r.out;
  const nlohmann::json summary = test::read_json(dir / "summary.json");
  EXPECT_EQ(summary.value(nlohmann::json::json_pointer("/run/solver/type"), ""), "adr") << summary;
  const nlohmann::json steps = summary.value("steps", nlohmann::json::array());
  EXPECT_TRUE(std::any_of(steps.begin(), steps.end(), [](const nlohmann::json& step) {
    return step.contains(nlohmann::json::json_pointer("/counts/adr_iterations"));
  })) << summary;
  EXPECT_EQ(summary.value("status", ""), "completed");
}

// 20 iterations cannot reach 1e-8 (the smoke plate needs about 120 per step).
TEST(AdrCli, ExhaustedBudgetStopsWithExitCode3) {
  const auto dir = test::fresh_directory("adr_fail");
  const auto r = test::run_cli("run " + kTension + " --solver adr --out " + dir.string() + kSmoke +
                               " --set solver.adr.max_iterations=20");
  EXPECT_EQ(r.exit_code, 3) << r.out << r.err;
  EXPECT_NE(r.err.find("ADR budget of 20 iterations reached"), std::string::npos) << r.err;
  EXPECT_NE(test::read_file(dir / "summary.json").find("\"no_convergence\""), std::string::npos);
}

TEST(AdrCli, AcceptedBudgetKeepsTheStateAndSaysSo) {
  const auto dir = test::fresh_directory("adr_accept");
  const auto r = test::run_cli("run " + kTension + " --solver adr --out " + dir.string() + kSmoke +
                               " --set solver.adr.max_iterations=20 --set solver.adr.on_budget=accept");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("NOT converged, kept"), std::string::npos) << r.out;
  const nlohmann::json summary = test::read_json(dir / "summary.json");
  const nlohmann::json steps = summary.value("steps", nlohmann::json::array());
  EXPECT_TRUE(std::any_of(steps.begin(), steps.end(), [](const nlohmann::json& step) {
    return step.value(nlohmann::json::json_pointer("/counts/unconverged_substeps"), 0.0) == 1.0;
  })) << summary;
}

}  // namespace
}  // namespace peristat
