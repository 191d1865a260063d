// The K-field boundary condition's displacement (src/core/k_field.hpp) against two
// properties of LEFM's near-tip field that its formula does not state directly: the jump
// across the faces behind the tip, (kappa + 1) K / mu sqrt(r / 2 pi) in opening (K_I) and in
// sliding (K_II), and the stress ahead of it, sigma_nn = K_I / sqrt(2 pi r) and sigma_tn =
// K_II / sqrt(2 pi r), from the field's finite-difference gradient and plane-stress Hooke.
// A tip away from the origin and a crack at 30 degrees, so that a frame error shows.
#include <cmath>
#include <numbers>

#include <gtest/gtest.h>

#include "core/k_field.hpp"

namespace peristat {
namespace {

constexpr double kE = 10.0e9, kNu = 0.3;

KField field(double K_I, double K_II) {
  KField k;
  k.K_I = K_I;
  k.K_II = K_II;
  k.tip = Vec2(0.3, -0.2);
  k.direction = Vec2(std::cos(std::numbers::pi / 6), std::sin(std::numbers::pi / 6));
  k.mu = kE / (2.0 * (1.0 + kNu));
  k.kappa = (3.0 - kNu) / (1.0 + kNu);
  return k;
}

TEST(KFieldFormula, FacesOpenAndSlideByLefmsJump) {
  const double K_I = 1.0e6, K_II = 0.4e6;
  const KField k = field(K_I, K_II);
  const Vec2 t = k.direction, n(-t.y(), t.x());
  for (double r : {1e-3, 0.05, 0.7}) {
    const Vec2 behind = k.tip - r * t, eps = 1e-12 * n;  // the two faces at distance r
    const Vec2 jump = k.at(behind + eps) - k.at(behind - eps);
    const double expected = (k.kappa + 1.0) / k.mu * std::sqrt(r / (2.0 * std::numbers::pi));
    EXPECT_NEAR(jump.dot(n), expected * K_I, 1e-9 * expected * K_I) << r;
    EXPECT_NEAR(jump.dot(t), expected * K_II, 1e-9 * expected * K_I) << r;
  }
}

TEST(KFieldFormula, StressAheadOfTheTipIsLefms) {
  const double K_I = 0.7e6, K_II = -0.3e6;
  const KField k = field(K_I, K_II);
  const Vec2 t = k.direction, n(-t.y(), t.x());
  for (double r : {1e-3, 0.05, 0.7}) {
    const Vec2 X = k.tip + r * t;
    const double h = 1e-6 * r;
    Eigen::Matrix2d grad;  // d u_i / d x_j by central differences
    for (int j = 0; j < 2; ++j) {
      Vec2 e = Vec2::Zero();
      e[j] = h;
      grad.col(j) = (k.at(X + e) - k.at(X - e)) / (2.0 * h);
    }
    const Eigen::Matrix2d strain = 0.5 * (grad + grad.transpose());
    const Eigen::Matrix2d stress =
        kE / (1.0 - kNu * kNu) * ((1.0 - kNu) * strain + kNu * strain.trace() * Eigen::Matrix2d::Identity());
    const double scale = 1.0 / std::sqrt(2.0 * std::numbers::pi * r);
    EXPECT_NEAR(n.dot(stress * n), K_I * scale, 1e-6 * K_I * scale) << r;
    EXPECT_NEAR(t.dot(stress * n), K_II * scale, 1e-6 * K_I * scale) << r;
  }
}

}  // namespace
}  // namespace peristat
