// Failure criteria on single families (issue 5): the critical values of the paper's case
// 4.4, the skew of a rigid rotation (zero) and of a simple shear (its amount), and the
// stretch of single bonds either side of the threshold.
#include <algorithm>
#include <cmath>
#include <numbers>
#include <vector>

#include <gtest/gtest.h>

#include "discretisation/model.hpp"
#include "materials/failure.hpp"

namespace peristat {
namespace {

// Closed-crack LEFM start stress (docs/theory/failure.md): hand values. theta = 45 deg,
// f_c = 0: sin cos = 1/2, so sigma_c = 2 sqrt(E G_c / (pi a)) = 5.0463 MPa for E = 10 GPa,
// G_c = 100 J/m^2, a = 0.05 m (sqrt(6.3662e12) = 2.52313e6). The friction factor
// 1 / (sin cos - f cos^2) at 45 deg is 1 / (0.5 - 0.5 f): 2.5 at f_c = 0.2 against 2 at
// f_c = 0 (ratio 1.25). Locked faces (theta = 30 deg, f_c = 0.6 > tan 30 deg = 0.577)
// never start.
TEST(FailureCriteria, ClosedCrackStartStress) {
  const double pi = std::numbers::pi;
  const double s0 = closed_crack_start_stress(10e9, 100.0, 0.05, pi / 4, 0.0);
  EXPECT_NEAR(s0, 2.0 * std::sqrt(10e9 * 100.0 / (pi * 0.05)), 1e-6);
  EXPECT_NEAR(s0, 5.04626e6, 1.0e1);
  EXPECT_NEAR(closed_crack_start_stress(10e9, 100.0, 0.05, pi / 4, 0.2) / s0, 1.25, 1e-12);
  EXPECT_NEAR(closed_crack_start_stress(10e9, 100.0, 0.05, pi / 3, 0.4),
              std::sqrt(10e9 * 100.0 / (pi * 0.05)) / (std::sqrt(3.0) / 4.0 - 0.4 * 0.25), 1e-6);
  EXPECT_TRUE(std::isinf(closed_crack_start_stress(10e9, 100.0, 0.05, pi / 6, 0.6)));
  EXPECT_FALSE(std::isinf(closed_crack_start_stress(10e9, 100.0, 0.05, pi / 6, 0.57)));
}

// Case 4.4: E = 10 GPa, nu = 0.3, G_c = 50 kJ/m^2, delta = 0.06 m. Reference values computed
// by hand from the formulas (python, double precision): mu = 3.846e9 Pa, plane-stress
// kappa = E / (2 (1 - nu)) = 7.143e9 Pa.
TEST(FailureCriteria, CriticalValuesOfCase44) {
  const double E = 10e9, nu = 0.3, mu = E / (2 * (1 + nu)), kappa = E / (2 * (1 - nu));
  EXPECT_NEAR(critical_skew(5e4, mu, 0.06), 0.028243052414718445, 1e-15);
  EXPECT_NEAR(critical_stretch(5e4, kappa, mu, 0.06), 0.010723608982040467, 1e-15);
}

std::vector<Vec2> family(double dx) {
  const Stencil st = make_stencil(3.0, dx, Quadrature::isotropic);
  std::vector<Vec2> xi;
  for (const auto& o : st.offset) xi.emplace_back(o[0] * dx, o[1] * dx);
  return xi;
}

Mat2 rotation(double a) { return (Mat2() << std::cos(a), -std::sin(a), std::sin(a), std::cos(a)).finished(); }

TEST(FailureCriteria, ReferenceBondIsTheShortestAlongTheDirection) {
  const std::vector<Vec2> xi = family(1.0);
  const Index r = reference_bond(xi, Vec2(1.0, 1.0));
  ASSERT_GE(r, 0);
  EXPECT_NEAR(std::abs(xi[r].x()), 1.0, 1e-15);  // the diagonal neighbour (+-1, +-1)
  EXPECT_NEAR(xi[r].x(), xi[r].y(), 1e-15);
}

// A broken bond is never a reference: with the two diagonal bonds (1,1) and (-1,-1)
// broken, the next closest direction to (1,1) with the shortest length is (2,2)'s pair,
// and with those broken too, a bond 11.3 degrees off ((3,2), (2,3) or opposites; the
// partial-area stencil holds them, 3.6 dx long).
TEST(FailureCriteria, ReferenceBondIsIntact) {
  const std::vector<Vec2> xi = family(1.0);
  std::vector<double> weight(xi.size(), 1.0);
  auto break_direction = [&](double x, double y) {
    for (std::size_t b = 0; b < xi.size(); ++b)
      if (std::abs(xi[b].x() - x) < 1e-12 && std::abs(xi[b].y() - y) < 1e-12) weight[b] = 0.0;
  };
  break_direction(1, 1);
  break_direction(-1, -1);
  Index r = reference_bond(xi, Vec2(1.0, 1.0), weight);
  ASSERT_GE(r, 0);
  EXPECT_NEAR(std::abs(xi[r].x()), 2.0, 1e-15);
  EXPECT_NEAR(xi[r].x(), xi[r].y(), 1e-15);
  break_direction(2, 2);
  break_direction(-2, -2);
  r = reference_bond(xi, Vec2(1.0, 1.0), weight);
  ASSERT_GE(r, 0);
  EXPECT_NEAR(std::abs(xi[r].normalized().dot(Vec2(1.0, 1.0).normalized())), 5.0 / std::sqrt(26.0), 1e-12);
  EXPECT_GT(weight[r], 0.0);
  std::fill(weight.begin(), weight.end(), 0.0);
  EXPECT_EQ(reference_bond(xi, Vec2(1.0, 1.0), weight), -1);
}

// A rigid rotation by 0.3 rad: every bond's skew vanishes (round-off: 1e-12), with the
// paper's eq 22 (min_sin = 0) and with the default floor at 45 degrees.
TEST(FailureCriteria, RigidRotationHasNoSkew) {
  const std::vector<Vec2> xi = family(0.02);
  const Mat2 Q = rotation(0.3);
  std::vector<Vec2> eta;
  for (const Vec2& x : xi) eta.push_back(Q * x - x);
  std::vector<double> gamma(xi.size());
  const Index r = reference_bond(xi, Vec2(1.0, 1.0));
  for (const double min_sin : {0.0, std::sqrt(0.5)}) {
    bond_skews(xi, eta, r, min_sin, gamma);
    for (double g : gamma) EXPECT_LT(g, 1e-12);
  }
}

// Simple shear of amount g along the reference direction (45 degrees), then a rigid
// rotation. Paper's eq 22 (min_sin = 0): every bond not parallel to e1 has skew g (to 1e-9
// relative), the parallel ones 0.
TEST(FailureCriteria, SimpleShearGivesItsAmount) {
  const std::vector<Vec2> xi = family(0.02);
  const Vec2 e1 = Vec2(1.0, 1.0).normalized(), e2(-e1.y(), e1.x());
  const double g = 2e-3;
  const Mat2 Q = rotation(-0.2);
  std::vector<Vec2> eta;
  for (const Vec2& x : xi) eta.push_back(Q * (x + g * x.dot(e2) * e1) - x);
  std::vector<double> gamma(xi.size());
  bond_skews(xi, eta, reference_bond(xi, e1), 0.0, gamma);
  int parallel = 0;
  for (std::size_t b = 0; b < xi.size(); ++b) {
    if (std::abs(xi[b].dot(e2)) < 1e-9 * xi[b].norm()) {
      EXPECT_EQ(gamma[b], 0.0);
      ++parallel;
    } else {
      EXPECT_NEAR(gamma[b] / g, 1.0, 1e-9) << "bond " << b;
    }
  }
  EXPECT_EQ(parallel, 4);  // (1,1), (2,2) and their opposites lie within 3 dx
}

// The same shear with the offset across e1 floored at |xi| sin 45 deg (the default): bonds
// at 45 degrees or more from e1 still read g (1e-9), the shallower ones read
// g |xi . e2| / (|xi| sin 45) < g, the parallel ones 0 (they do not shear along e1).
TEST(FailureCriteria, SimpleShearWithTheFloor) {
  const std::vector<Vec2> xi = family(0.02);
  const Vec2 e1 = Vec2(1.0, 1.0).normalized(), e2(-e1.y(), e1.x());
  const double g = 2e-3, s = std::sqrt(0.5);
  const Mat2 Q = rotation(-0.2);
  std::vector<Vec2> eta;
  for (const Vec2& x : xi) eta.push_back(Q * (x + g * x.dot(e2) * e1) - x);
  std::vector<double> gamma(xi.size());
  bond_skews(xi, eta, reference_bond(xi, e1), s, gamma);
  int steep = 0, shallow = 0;
  for (std::size_t b = 0; b < xi.size(); ++b) {
    const double sin_b = std::abs(xi[b].dot(e2)) / xi[b].norm();
    if (sin_b >= s - 1e-12) {
      EXPECT_NEAR(gamma[b] / g, 1.0, 1e-9) << "bond " << b;
      ++steep;
    } else {
      EXPECT_NEAR(gamma[b], g * sin_b / s, 1e-9 * g) << "bond " << b;
      ++shallow;
    }
  }
  EXPECT_GT(steep, 0);
  EXPECT_GT(shallow, 4);  // more than the four parallel bonds
}

// Single bonds below, at and above the critical stretch of case 4.4: the stretch the
// criterion compares with s_c is exact to round-off, so a bond at 0.999 s_c stays below,
// at s_c reads s_c (1e-12) and at 1.001 s_c is above.
TEST(FailureCriteria, StretchEitherSideOfTheThreshold) {
  const double E = 10e9, nu = 0.3, mu = E / (2 * (1 + nu)), kappa = E / (2 * (1 - nu));
  const double sc = critical_stretch(5e4, kappa, mu, 0.06);
  const Vec2 xi(0.02, 0.04);
  for (double f : {0.999, 1.0, 1.001}) {
    const double s = bond_stretch(xi, f * sc * xi);
    if (f < 1.0) {
      EXPECT_LT(s, sc);
    } else if (f > 1.0) {
      EXPECT_GT(s, sc);
    } else {
      EXPECT_NEAR(s / sc, 1.0, 1e-12);
    }
  }
}

}  // namespace
}  // namespace peristat
