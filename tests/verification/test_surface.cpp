// Surface correction (issue 13): a tension plate whose free edges and grips should leave
// the continuum's uniform uniaxial field, measured as the table does. An affine
// fit of the displacements over the region two horizons inside every edge gives
// nu_apparent = -e_yy / e_xx. The field's uniformity is the spread of e_xx over 4 x 4
// windows of that region.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>
#include <utility>
#include <vector>

#include "support/scenes.hpp"
#include "support/solve.hpp"

namespace peristat {
namespace {

struct PlateMeasure {
  double nu_two = 0.0;     ///< -e_yy / e_xx fitted two horizons inside
  double nu_one = 0.0;     ///< the same one horizon inside
  double exx_spread = 0.0; ///< (max - min) / mean of e_xx over 4 x 4 windows, two horizons inside
  double syy_ratio = 0.0;  ///< |mean sigma_yy / mean sigma_xx| over the region two horizons inside
};

/// grips "layers": the 3 fictitious layers of test::tension_boundary (ux held at one value
/// over each grip's depth); "surface": `layers: 0`, ux prescribed on the body's outermost
/// column at each end; "mirror": `mirror: true`, the plate reflected across each end edge
/// (docs/theory/osb.md, section 7).
PlateMeasure measure_plate(double nu, double dx, const std::string& correction, const std::string& grips,
                           double side = 0.1) {
  const int n_side = static_cast<int>(std::lround(side / dx));
  test::PlateSpec spec;
  spec.nx = spec.ny = n_side;
  spec.dx = dx;
  spec.nu = nu;
  spec.E = 70e9;
  spec.kinematics = "small";
  spec.surface_correction = correction;
  spec.boundary = grips == "surface"  ? test::surface_tension_boundary(1e-3, spec)
                  : grips == "mirror" ? test::mirror_tension_boundary(1e-3, spec)
                                      : test::tension_boundary(1e-3, spec);
  spec.solver = "  linear: cholmod\n  newton: {rtol: 1.0e-12}\n";
  auto s = test::solve_scene(test::plate_yaml(spec));
  EXPECT_TRUE(s->run.completed) << s->run.message;
  const double L = n_side * dx, delta = 3.0 * dx;
  auto nu_inside = [&](double inset) {
    const Vec2 lo(inset, inset), hi(L - inset, L - inset);
    const double exx = test::fit_affine(*s, 0, lo, hi)[1], eyy = test::fit_affine(*s, 1, lo, hi)[2];
    return -eyy / exx;
  };
  PlateMeasure m;
  m.nu_two = nu_inside(2.0 * delta);
  m.nu_one = nu_inside(1.0 * delta);
  const double a = 2.0 * delta, w = (L - 2.0 * a) / 4.0;
  double lo_e = 1e300, hi_e = -1e300, sum = 0.0;
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) {
      const Vec2 lo(a + i * w, a + j * w), hi(a + (i + 1) * w, a + (j + 1) * w);
      const double e = test::fit_affine(*s, 0, lo, hi)[1];
      lo_e = std::min(lo_e, e);
      hi_e = std::max(hi_e, e);
      sum += e;
    }
  m.exx_spread = (hi_e - lo_e) / (sum / 16.0);
  Mat2 P = Mat2::Zero();
  for (Index i = 0; i < s->model.particles.size(); ++i) {
    const Vec2& X = s->model.particles.position[i];
    if (!s->model.particles.fictitious[i] && X.x() > a && X.x() < L - a && X.y() > a && X.y() < L - a)
      P += s->problem->stress(i);
  }
  m.syy_ratio = std::abs(P(1, 1) / P(0, 0));
  const SurfaceCorrectionStats& st = s->problem->surface_correction().stats();
  std::printf("nu %.3f dx %.0e %-8s %-7s grips: nu_app %.5f (%+.2f%%) one horizon in %.5f (%+.2f%%), e_xx spread %.3f%%, "
              "|s_yy/s_xx| %.2e; omega [%.3f, %.3f], %ld corrected, %ld clipped, %ld unmatched\n",
              nu, dx, correction.c_str(), grips.c_str(), m.nu_two, nu > 0 ? 100.0 * (m.nu_two / nu - 1.0) : 0.0, m.nu_one,
              nu > 0 ? 100.0 * (m.nu_one / nu - 1.0) : 0.0, 100.0 * m.exx_spread, m.syy_ratio, st.min_influence,
              st.max_influence, static_cast<long>(st.corrected), static_cast<long>(st.clipped),
              static_cast<long>(st.unmatched));
  return m;
}

// The acceptance of issue 13: the corrected model with mirror grips (each end a frictionless
// platen, the plate reflected across it; docs/theory/osb.md section 7) gives the
// continuum's uniform uniaxial field. Tolerances are the issue's: nu within 1% two horizons
// inside (0.003 absolute at nu = 0) and within 2% one horizon inside; e_xx uniform to 0.2%;
// interior |sigma_yy / sigma_xx| < 1e-3. Measured 2026-11-24: nu within 0.02%, spread
// <= 0.02%, |sigma_yy / sigma_xx| <= 1.9e-4.
/// nu within 1% two horizons inside and 2% one horizon inside (0.003 and 0.006 absolute at
/// nu = 0); e_xx spread and |sigma_yy / sigma_xx| below the given bounds.
void expect_uniaxial(const PlateMeasure& m, double nu, double spread, double syy) {
  const double tol_two = nu > 0 ? 0.01 * nu : 0.003, tol_one = nu > 0 ? 0.02 * nu : 0.006;
  EXPECT_NEAR(m.nu_two, nu, tol_two);
  EXPECT_NEAR(m.nu_one, nu, tol_one);
  EXPECT_LT(m.exx_spread, spread);
  EXPECT_LT(m.syy_ratio, syy);
}

class SurfaceCorrected : public ::testing::TestWithParam<std::tuple<double, double>> {};

TEST_P(SurfaceCorrected, TensionPlateIsUniaxial) {
  const auto [nu, dx] = GetParam();
  expect_uniaxial(measure_plate(nu, dx, "moments", "mirror"), nu, 2e-3, 1e-3);
}

INSTANTIATE_TEST_SUITE_P(PoissonAndSpacing, SurfaceCorrected,
                         ::testing::Combine(::testing::Values(0.0, 0.2, 0.3, 0.45), ::testing::Values(1e-3, 2e-3)));

// Grips on the body's own end columns (`layers: 0`) hold u_x over one spacing and leave a
// soft end zone: nu still within the 1%, but e_xx varies by up to 0.31% and
// |sigma_yy / sigma_xx| reaches 3.9e-3 (measured 2026-11-24, worst at nu = 0.45 and
// dx = 2 mm). Asserted at the measured level with a margin: a documented alternative, not
// the acceptance.
class SurfaceGripped : public ::testing::TestWithParam<std::tuple<double, double>> {};

TEST_P(SurfaceGripped, TensionPlateNearlyUniaxial) {
  const auto [nu, dx] = GetParam();
  expect_uniaxial(measure_plate(nu, dx, "moments", "surface"), nu, 3.5e-3, 4.5e-3);
}

INSTANTIATE_TEST_SUITE_P(PoissonAndSpacing, SurfaceGripped,
                         ::testing::Combine(::testing::Values(0.2, 0.45), ::testing::Values(1e-3, 2e-3)));

// The same plates uncorrected, with the fictitious-layer grips of the paper: the distortion
// the issue reported, kept as a measured contrast (nu at least 2.5% low for nu >= 0.2).
TEST(SurfaceUncorrected, LayerGripsDistortTheField) {
  for (double nu : {0.2, 0.3, 0.45}) {
    const PlateMeasure m = measure_plate(nu, 1e-3, "none", "layers");
    EXPECT_LT(m.nu_two, 0.975 * nu);
  }
}

// Which part is the grips' and which the edges': every combination at nu = 0.3, dx = 1 mm.
// Measured nu errors: layers/none -3.74%, layers/moments -3.30%, surface/none -0.61%,
// surface/moments -0.26%, mirror/moments -0.003%. Asserted: that order, each step at least
// 0.2 points better, so the grips carry most of the distortion and the correction helps
// with either of the first two grips; the mirror grip removes what is left to 0.05%.
TEST(SurfaceGrips, CauseMostOfTheDistortion) {
  std::vector<double> error;
  for (const auto& [c, g] : {std::pair{"none", "layers"}, std::pair{"moments", "layers"}, std::pair{"none", "surface"},
                             std::pair{"moments", "surface"}})
    error.push_back(std::abs(measure_plate(0.3, 1e-3, c, g).nu_two / 0.3 - 1.0));
  for (std::size_t k = 1; k < error.size(); ++k) EXPECT_LT(error[k], error[k - 1] - 2e-3) << k;
  // The grips' share is larger than the correction's.
  EXPECT_GT(error[0] - error[2], 5.0 * (error[0] - error[1]));
  EXPECT_LT(std::abs(measure_plate(0.3, 1e-3, "moments", "mirror").nu_two / 0.3 - 1.0), 5e-4);
}

}  // namespace
}  // namespace peristat
