// An open crack under mixed mode (issue 45 item 3; docs/verification.md "Kinks of open cracks
// under mixed mode"): cases/mixed_mode_crack, a centre crack of length 2a = 0.2 m in a 1 m
// plate whose boundary follows the affine field of the remote stress sigma_nn = sigma,
// sigma_tn = tau (K_II / K_I = tau / sigma), critical stretch, dx = 10 mm (delta / a = 0.3).
// The maximum-tangential-stress criterion (MTS, Erdogan and Sih) is the reference for the
// start load and the kink. What is asserted, and why:
// - the start load (first bond, from the linear response below it) within 12% of MTS's for
//   K_II / K_I = 0, 0.5, 1, with the crack along the lattice and at 30 degrees to it.
//   Measured (2026-12-02): 1.082, 0.932, 0.961 along the lattice; 0.930, 1.041, 0.964 at 30
//   degrees. The first bond's load moves by +-8% with where the tip sits in its cell
//   (verification.KField: 0.72-1.20 on the exact LEFM field), so 12% is what a correct
//   criterion may miss by; an error in the criterion or the field misses by much more;
// - the crack grown at K_II / K_I = 1 turns the way MTS says (clockwise at the right tip), by
//   at least 10 degrees, and both tips agree to 2 degrees: the problem is symmetric under a
//   half turn about the plate's centre, lattice included, and every round breaks all the
//   bonds over the criterion, so a growth that treats the tips differently is a defect.
//   Measured: -14 / -22 degrees in the rings [0, 2] / [2, 5] delta about either tip (MTS:
//   -53.1; the plane normal to the remote sigma_1: -31.7). The kink is NOT asserted within
//   10 degrees of MTS, because it is not: at delta / a = 0.3 the field over a horizon is not
//   the K-field, and the lattice pulls the path (docs/verification.md, with the sizes).
#include <cmath>
#include <numbers>
#include <string>
#include <vector>

#include <Eigen/Eigenvalues>
#include <gtest/gtest.h>

#include "discretisation/model.hpp"
#include "materials/bond_failure.hpp"
#include "support/solve.hpp"

namespace peristat {
namespace {

constexpr double kE = 10.0e9, kNu = 0.3, kGc = 100.0, kA = 0.1;
const Vec2 kCentre(0.5, 0.5);

/// MTS: the kink angle [rad] and g = K_tt,max / K_I for K_II / K_I = r.
std::pair<double, double> mts(double r) {
  const double theta = r == 0.0 ? 0.0 : 2.0 * std::atan((1.0 - std::sqrt(1.0 + 8.0 * r * r)) / (4.0 * r));
  const double c = std::cos(theta / 2);
  return {theta, c * (c * c - 1.5 * r * std::sin(theta))};
}

/// Overrides of cases/mixed_mode_crack for a crack along `angle` [rad] under the remote
/// sigma_nn = sigma, sigma_tn = tau (plane stress; the symmetric gradient, no rotation).
std::vector<std::string> loading(double sigma, double tau, double angle, int steps) {
  const Vec2 t(std::cos(angle), std::sin(angle)), n(-t.y(), t.x());
  Eigen::Matrix2d s = sigma * n * n.transpose() + tau * (t * n.transpose() + n * t.transpose());
  const Eigen::Matrix2d g = ((1.0 + kNu) * s - kNu * s.trace() * Eigen::Matrix2d::Identity()) / kE;
  const Vec2 p0 = kCentre - kA * t, p1 = kCentre + kA * t;
  auto num = [](double v) {
    char b[40];
    std::snprintf(b, sizeof b, "%.17g", v);
    return std::string(b);
  };
  return {"loading.steps=" + std::to_string(steps),
          "cracks.0.from=[" + num(p0.x()) + ", " + num(p0.y()) + "]",
          "cracks.0.to=[" + num(p1.x()) + ", " + num(p1.y()) + "]",
          "boundary.0.ux={grad: [" + num(g(0, 0)) + ", " + num(g(0, 1)) + "]}",
          "boundary.0.uy={grad: [" + num(g(1, 0)) + ", " + num(g(1, 1)) + "]}"};
}

double mts_start(double r) { return std::sqrt(kE * kGc) / (std::sqrt(std::numbers::pi * kA) * mts(r).second); }

TEST(Kink, OpenCrackStartsWhereMtsSays) {
  for (double angle_deg : {0.0, 30.0}) {
    for (double r : {0.0, 0.5, 1.0}) {
      const double sigma = 0.5 * mts_start(r);  // half the start: no bond breaks, the response is linear
      auto s = test::solve_case("mixed_mode_crack", loading(sigma, r * sigma, angle_deg * std::numbers::pi / 180, 1));
      ASSERT_TRUE(s->run.completed);
      ASSERT_EQ(s->problem->failure()->broken(), 0);
      const double start = 0.5 / s->problem->failure()->peak().ratio;
      std::printf("crack at %2.0f deg to the lattice, K_II/K_I = %.1f: start / MTS %.3f\n", angle_deg, r, start);
      EXPECT_NEAR(start, 1.0, 0.12) << angle_deg << " " << r;
    }
  }
}

/// Angle [deg] from `forward` (counter-clockwise positive) of the damage-weighted principal
/// axis through `tip` of the particles with damage >= 0.2 in the ring lo < |x - tip| <= hi,
/// ahead of or beside the tip (scripts/lefm-kink measures the same).
double ring_axis(const Model& m, const VectorXd& d, const Vec2& tip, const Vec2& forward, double lo, double hi) {
  Eigen::Matrix2d S = Eigen::Matrix2d::Zero();
  int n = 0;
  for (Index i = 0; i < m.particles.size(); ++i) {
    if (m.particles.fictitious[i] || d[i] < 0.2) continue;
    const Vec2 x = m.particles.position[i] - tip;
    const double r = x.norm();
    if (r <= lo || r > hi || x.dot(forward) <= -0.5 * r) continue;
    S += d[i] * x * x.transpose();
    ++n;
  }
  EXPECT_GE(n, 3) << "too few damaged particles in the ring";
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eig(S);
  Vec2 v = eig.eigenvectors().col(1);
  if (v.dot(forward) < 0) v = -v;
  return std::atan2(forward.x() * v.y() - forward.y() * v.x(), forward.dot(v)) * 180.0 / std::numbers::pi;
}

TEST(Kink, MixedModeCrackTurnsTheWayMtsSaysAtBothTips) {
  auto s = test::solve_case("mixed_mode_crack", {});  // K_II / K_I = 1, 1.6 MPa each, 10 steps
  ASSERT_TRUE(s->run.completed) << s->run.message;
  VectorXd d;
  s->problem->failure()->damage(d);
  const double delta = s->model.horizon;
  const Vec2 right = kCentre + Vec2(kA, 0), left = kCentre - Vec2(kA, 0);
  for (auto [lo, hi] : {std::pair{0.0, 2.0}, std::pair{2.0, 5.0}}) {
    const double a_right = ring_axis(s->model, d, right, Vec2(1, 0), lo * delta, hi * delta);
    const double a_left = ring_axis(s->model, d, left, Vec2(-1, 0), lo * delta, hi * delta);
    std::printf("ring [%g, %g] delta: %+.1f (right tip) %+.1f (left tip) deg; MTS %+.1f\n", lo, hi, a_right, a_left,
                mts(1.0).first * 180.0 / std::numbers::pi);
    EXPECT_NEAR(a_right, a_left, 2.0);
    EXPECT_LT(a_right, -10.0);
    EXPECT_GT(a_right, -63.1);  // not past MTS's -53.1 by more than the 10 degrees
  }
}

// The same crack tip in a pure K-field (cases/k_field_boundary_layer: the rim follows LEFM's
// near-tip field, so no finite crack, no T-stress), K_I = K_II = 1.6 x MTS's start, ten
// steps, the crack along the lattice with its tip at a cell corner. Here the kink is MTS's:
// measured -58.5 degrees in [0, 2] delta and -57.3 in [2, 5] delta against -53.1, so the
// issue's 10 degrees hold. (At 30 degrees to the lattice they do not: -36 / -40, the
// lattice's pull; docs/verification.md.)
TEST(Kink, PureKFieldAlongTheLatticeKinksWithinTenDegreesOfMts) {
  const double k = 1.6 * std::sqrt(kE * kGc) / mts(1.0).second;  // K_I = K_II
  char field[160];
  std::snprintf(field, sizeof field, "boundary.0.k_field={K_I: %.17g, K_II: %.17g, tip: [0, 0], direction: [1, 0]}",
                k, k);
  auto s = test::solve_case("k_field_boundary_layer", {field, "failure.criterion=stretch", "loading.steps=10"});
  ASSERT_TRUE(s->run.completed) << s->run.message;
  VectorXd d;
  s->problem->failure()->damage(d);
  const double delta = s->model.horizon, theta = mts(1.0).first * 180.0 / std::numbers::pi;
  for (auto [lo, hi] : {std::pair{0.0, 2.0}, std::pair{2.0, 5.0}}) {
    const double a = ring_axis(s->model, d, Vec2::Zero(), Vec2(1, 0), lo * delta, hi * delta);
    std::printf("pure K-field, ring [%g, %g] delta: %+.1f deg; MTS %+.1f\n", lo, hi, a, theta);
    EXPECT_NEAR(a, theta, 10.0);
  }
}

}  // namespace
}  // namespace peristat
