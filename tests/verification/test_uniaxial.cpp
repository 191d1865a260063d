// Uniaxial tension: the effective Young's modulus and Poisson's ratio measured in the
// interior of a plate match the input within 1% (issue 2). Strains come from an affine fit
// of the solved displacements, stresses from the force state (P = sum t M xi^T, the
// derivative of the PD energy density with respect to a homogeneous deformation).
#include <gtest/gtest.h>

#include "support/scenes.hpp"
#include "support/solve.hpp"

namespace peristat {
namespace {

struct Measured {
  double E, nu, sigma_yy_ratio;
};

Measured measure(double nu, const std::string& quadrature, const std::string& kinematics) {
  test::PlateSpec spec;
  spec.nx = 60;
  spec.ny = 30;
  spec.nu = nu;
  spec.E = 70e9;
  spec.quadrature = quadrature;
  spec.kinematics = kinematics;
  const double strain = 1e-4;
  spec.boundary = test::tension_boundary(strain, spec);
  spec.solver = "  newton: {rtol: 1.0e-12}\n";
  auto s = test::solve_scene(test::plate_yaml(spec));
  EXPECT_TRUE(s->run.completed) << s->run.message;
  // Central window, two horizons and more from every boundary: [0.35 L, 0.65 L] x [0.3 H, 0.7 H].
  const double L = spec.nx * spec.dx, H = spec.ny * spec.dx;
  const Vec2 lo(0.35 * L, 0.3 * H), hi(0.65 * L, 0.7 * H);
  const Eigen::Vector3d fx = test::fit_affine(*s, 0, lo, hi), fy = test::fit_affine(*s, 1, lo, hi);
  const double exx = fx[1], eyy = fy[2];
  Mat2 P = Mat2::Zero();
  int n = 0;
  for (Index i = 0; i < s->model.particles.size(); ++i) {
    const Vec2& X = s->model.particles.position[i];
    if ((X.array() >= lo.array()).all() && (X.array() <= hi.array()).all()) {
      P += s->problem->stress(i);
      ++n;
    }
  }
  P /= n;
  // Invert the isotropic plane-stress law E e_xx = s_xx - nu s_yy, E e_yy = s_yy - nu s_xx
  // with both measured stresses, so a small residual s_yy does not bias nu.
  const double sxx = P(0, 0), syy = P(1, 1);
  const double nu_eff = (syy * exx - sxx * eyy) / (sxx * exx - syy * eyy);
  const double E_eff = (sxx - nu_eff * syy) / exx;
  return {E_eff, nu_eff, std::abs(syy / sxx)};
}

class Uniaxial : public ::testing::TestWithParam<double> {};

TEST_P(Uniaxial, EffectiveModuliWithinOnePercent) {
  const double nu = GetParam();
  const Measured m = measure(nu, "isotropic", "small");
  RecordProperty("E_ratio", std::to_string(m.E / 70e9));
  RecordProperty("nu_ratio", std::to_string(m.nu / nu));
  std::printf("nu = %.2f: E_eff / E = %.5f, nu_eff / nu = %.5f, |s_yy / s_xx| = %.2e\n", nu, m.E / 70e9,
              m.nu / nu, m.sigma_yy_ratio);
  EXPECT_NEAR(m.E / 70e9, 1.0, 0.01);
  EXPECT_NEAR(m.nu / nu, 1.0, 0.01);
  EXPECT_LT(m.sigma_yy_ratio, 0.01);  // the interior is in uniaxial stress
}

INSTANTIATE_TEST_SUITE_P(PoissonRatios, Uniaxial, ::testing::Values(0.2, 0.3, 0.45));

// Finite kinematics at a strain of 1e-4 gives the same moduli (the nonlinearity is O(strain)).
TEST(UniaxialFinite, SameModuliAsSmall) {
  const Measured m = measure(0.3, "isotropic", "finite");
  std::printf("finite kinematics, nu = 0.3: E_eff / E = %.5f, nu_eff / nu = %.5f\n", m.E / 70e9, m.nu / 0.3);
  EXPECT_NEAR(m.E / 70e9, 1.0, 0.01);
  EXPECT_NEAR(m.nu / 0.3, 1.0, 0.01);
}

// Without the fourth-harmonic correction the square lattice is anisotropic: the partial-area
// quadrature alone misses nu by about 4% at nu = 0.2 (docs/theory/osb.md). This documents
// why `isotropic` is the default; the assertion is that the error is really there.
TEST(UniaxialQuadrature, PartialAreasAloneAreAnisotropic) {
  const Measured m = measure(0.2, "partial", "small");
  std::printf("partial quadrature, nu = 0.2: E_eff / E = %.5f, nu_eff / nu = %.5f\n", m.E / 70e9, m.nu / 0.2);
  EXPECT_GT(std::abs(m.nu / 0.2 - 1.0), 0.02);
}

}  // namespace
}  // namespace peristat
