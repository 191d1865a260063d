// The size estimate made before discretising (issue 15, src/app/preflight.cpp) against the
// sizes measured on the built model: it decides whether a run is refused, so it must be of
// the right size. Measured 2026-11-24: memory within 8% on the tension plate, the paper's
// case 4.4 and the LEFM case (157 against 146 MB, 274 against 290 MB, 577 against 606 MB).
#include <chrono>
#include <cmath>
#include <string>

#include <gtest/gtest.h>

#include "app/model_size.hpp"
#include "app/preflight.hpp"
#include "app/setup.hpp"
#include "scene/scene.hpp"

namespace peristat {
namespace {

void expect_close(const std::string& scene_file) {
  const Scene scene = parse_scene(std::string(PERISTAT_SOURCE_DIR) + "/cases/" + scene_file);
  const SizeEstimate e = estimate_size(scene);
  const Model model = discretise(scene);
  const QuasiStaticProblem problem(model, problem_options(scene));
  const ModelSize size = measure(model, problem);
  // 15%: the estimate counts areas and edge strips, not lattice points, and prices every
  // nonzero alike; a refusal is about orders of magnitude, not percents.
  EXPECT_NEAR((e.particles + e.fictitious) / size.particles, 1.0, 0.15) << scene_file;
  EXPECT_NEAR(e.nonzeros / static_cast<double>(size.nonzeros), 1.0, 0.15) << scene_file;
  EXPECT_NEAR(e.memory_bytes / size.memory_bytes, 1.0, 0.15) << scene_file;
  EXPECT_EQ(e.family, static_cast<double>(model.stencil.offset.size())) << scene_file;
}

TEST(Preflight, EstimateMatchesTheBuiltModel) {
  expect_close("tension_plate/scene.yaml");
  expect_close("paper_4_4_crack_growth/scene.yaml");
}

// A scene that cannot fit is estimated (and refused) at once: no lattice is built.
TEST(Preflight, HugeScenesAreEstimatedWithoutBuildingThem) {
  const auto t0 = std::chrono::steady_clock::now();
  const Scene scene = parse_scene(std::string(PERISTAT_SOURCE_DIR) + "/cases/tension_plate/scene.yaml",
                                  {parse_override("discretization.spacing=1e-7")});
  const SizeEstimate e = estimate_size(scene);
  EXPECT_NEAR(e.particles, 1e12, 1e10);  // (0.1 m / 1e-7 m)^2
  EXPECT_THROW(preflight(scene, e), InputError);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  EXPECT_LT(seconds, 1.0);
}

}  // namespace
}  // namespace peristat
