// Refinement: the error against the analytic uniaxial-tension solution falls as dx falls
// with m fixed (issue 2). The plate keeps its size (40 mm x 20 mm); the prescribed layers
// carry the analytic ux = eps X on both ends, so the only error is the peridynamic one
// (surface softening along the free edges, which is confined to a layer of width ~delta).
#include <cmath>
#include <sstream>

#include <gtest/gtest.h>

#include "support/scenes.hpp"
#include "support/solve.hpp"

namespace peristat {
namespace {

double tension_error(int nx) {
  test::PlateSpec spec;
  spec.nx = nx;
  spec.ny = nx / 2;
  spec.dx = 0.04 / nx;
  spec.kinematics = "small";
  const double eps = 1e-4, H = spec.ny * spec.dx;
  std::ostringstream b;
  b.precision(17);
  b << "  - {body: plate, edge: left, ux: {grad: [" << eps << ", 0]}}\n"
    << "  - {body: plate, edge: right, ux: {grad: [" << eps << ", 0]}}\n"
    << "  - {body: plate, region: {min: [0, " << 0.5 * H - spec.dx << "], max: [" << spec.dx << ", "
    << 0.5 * H + spec.dx << "]}, uy: 0}\n";
  spec.boundary = b.str();
  auto s = test::solve_scene(test::plate_yaml(spec));
  EXPECT_TRUE(s->run.completed) << s->run.message;
  double err2 = 0.0, ref2 = 0.0;
  for (Index i = 0; i < s->model.particles.size(); ++i) {
    if (s->model.particles.fictitious[i]) continue;
    const Vec2& X = s->model.particles.position[i];
    const Vec2 exact(eps * X.x(), -spec.nu * eps * (X.y() - 0.5 * H));
    err2 += (Vec2(s->u[2 * i], s->u[2 * i + 1]) - exact).squaredNorm();
    ref2 += exact.squaredNorm();
  }
  return std::sqrt(err2 / ref2);
}

TEST(Refinement, ErrorFallsWithSpacing) {
  const int sizes[] = {20, 40, 80};
  double prev = 0.0;
  for (int nx : sizes) {
    const double e = tension_error(nx);
    std::printf("dx = %.3g mm: relative L2 error %.4e", 40.0 / nx, e);
    if (prev > 0.0) std::printf("  (observed order %.2f)", std::log2(prev / e));
    std::printf("\n");
    // Each halving of dx must cut the error by at least a quarter (first order would
    // halve it); a non-convergent discretisation would not.
    if (prev > 0.0) {
      EXPECT_LT(e, 0.75 * prev);
    }
    prev = e;
  }
}

}  // namespace
}  // namespace peristat
