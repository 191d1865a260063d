// Patch test: an affine displacement imposed on fictitious particles around a plate is
// reproduced at every real particle to solver tolerance (issue 2).
//
// Why 8 layers: the OSB force on particle i involves the dilatation of each neighbour j,
// which involves j's own family, so the affine field is an exact equilibrium at i only when
// every particle within two family radii (2 x 3.6 dx for m = 3) has a complete family.
// Eight layers of prescribed particles give that to every real particle, so the exact
// answer is the affine field everywhere, interior and boundary alike. With the default
// three layers the incomplete families of the outermost fictitious particles disturb the
// boundary (docs/verification.md reports the size of that disturbance).
#include <sstream>

#include <gtest/gtest.h>

#include "support/scenes.hpp"
#include "support/solve.hpp"

namespace peristat {
namespace {

const Mat2 kGradient = (Mat2() << 1.0e-3, 4.0e-4, -2.0e-4, -5.0e-4).finished();
const Vec2 kShift(1.0e-6, -2.0e-6);

std::string affine_surround(int layers) {
  std::ostringstream y;
  y.precision(17);
  y << "  - {body: plate, surround: true, layers: " << layers << ", ux: {value: " << kShift.x() << ", grad: ["
    << kGradient(0, 0) << ", " << kGradient(0, 1) << "]}, uy: {value: " << kShift.y() << ", grad: ["
    << kGradient(1, 0) << ", " << kGradient(1, 1) << "]}}\n";
  return y.str();
}

/// Largest |u - u_affine| over real particles, relative to the largest |u_affine|.
double patch_error(const std::string& kinematics, int layers) {
  test::PlateSpec spec;
  spec.nx = 16;
  spec.ny = 12;
  spec.kinematics = kinematics;
  spec.boundary = affine_surround(layers);
  spec.solver = "  newton: {rtol: 1.0e-13}\n";
  auto s = test::solve_scene(test::plate_yaml(spec));
  EXPECT_TRUE(s->run.completed) << s->run.message;
  double err = 0.0, ref = 0.0;
  for (Index i = 0; i < s->model.particles.size(); ++i) {
    if (s->model.particles.fictitious[i]) continue;
    const Vec2 exact = kShift + kGradient * s->model.particles.position[i];
    err = std::max(err, (Vec2(s->u[2 * i], s->u[2 * i + 1]) - exact).norm());
    ref = std::max(ref, exact.norm());
  }
  return err / ref;
}

// Tolerance 1e-9: Newton stops at a relative residual of 1e-13; the condition number of
// this small stiffness (~1e3-1e4) maps that to displacement errors of ~1e-10 at most.
TEST(Patch, SmallKinematicsReproducesAffineField) {
  const double err = patch_error("small", 8);
  std::printf("patch error, small kinematics, 8 layers: %.3e\n", err);
  EXPECT_LT(err, 1e-9);
}

// Finite kinematics: a homogeneous deformation with complete families is an exact
// equilibrium of the nonlinear model too.
TEST(Patch, FiniteKinematicsReproducesAffineField) {
  const double err = patch_error("finite", 8);
  std::printf("patch error, finite kinematics, 8 layers: %.3e\n", err);
  EXPECT_LT(err, 1e-9);
}

// The contrast that motivates 8 layers: with 3 layers the boundary is disturbed by far more
// than solver tolerance (measured 9.6e-3 relative; asserted above 1e-6).
TEST(Patch, ThreeLayersDisturbTheBoundary) {
  const double err = patch_error("small", 3);
  std::printf("patch error with 3 layers: %.3e\n", err);
  EXPECT_GT(err, 1e-6);
}

}  // namespace
}  // namespace peristat
