#include "materials/failure.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

namespace peristat {

namespace {
/// Cosines closer than this are the same lattice direction (the shortest bond wins).
constexpr double kSameDirection = 1e-12;
/// Relative length difference below which two bonds are equally long.
constexpr double kSameLength = 1e-9;
/// A bond whose offset across the reference direction is below this fraction of its length
/// is parallel to it and has no skew.
constexpr double kParallel = 1e-9;
}  // namespace

double critical_stretch(double G_c, double kappa, double mu, double delta) {
  const double pi = std::numbers::pi;
  return std::sqrt(G_c / ((6.0 * mu / pi + 16.0 * (kappa - 2.0 * mu) / (9.0 * pi * pi)) * delta));
}

double critical_skew(double G_c, double mu, double delta) {
  return std::sqrt(75.0 * std::numbers::pi * G_c / (64.0 * mu * delta));
}

double closed_crack_start_stress(double E, double G_c, double a, double theta, double f_c) {
  const double driving = std::sin(theta) * std::cos(theta) - f_c * std::cos(theta) * std::cos(theta);
  if (driving <= 0.0) return std::numeric_limits<double>::infinity();
  return std::sqrt(E * G_c / (std::numbers::pi * a)) / driving;
}

double bond_stretch(const Vec2& xi, const Vec2& eta) {
  return (xi + eta).norm() / xi.norm() - 1.0;
}

Index reference_bond(std::span<const Vec2> xi, const Vec2& direction, std::span<const double> weight) {
  const Vec2 d = direction.normalized();
  Index best = -1;
  double best_cos = -1.0, best_len = 0.0;
  for (std::size_t b = 0; b < xi.size(); ++b) {
    if (!weight.empty() && !(weight[b] > 0.0)) continue;
    const double len = xi[b].norm();
    const double c = std::abs(xi[b].dot(d)) / len;
    // Directions on a lattice repeat exactly; compare with a tolerance so that the
    // shortest of parallel bonds wins. Lengths too: the two senses of a direction are
    // equally long, and round-off in the positions must not pick one (the first in the
    // family's order does).
    if (c > best_cos + kSameDirection ||
        (std::abs(c - best_cos) <= kSameDirection && len < best_len * (1.0 - kSameLength))) {
      best = static_cast<Index>(b);
      best_cos = c;
      best_len = len;
    }
  }
  return best;
}

void bond_skews(std::span<const Vec2> xi, std::span<const Vec2> eta, Index r, double min_sin,
                std::span<double> gamma) {
  const Vec2& x0 = xi[r];
  const Vec2 y0 = x0 + eta[r];
  // R: the rotation taking x0's direction to y0's (eqs 20-21).
  const double beta = std::atan2(y0.y(), y0.x()) - std::atan2(x0.y(), x0.x());
  const double c = std::cos(beta), s = std::sin(beta);
  const Vec2 e1 = x0.normalized(), e2(-e1.y(), e1.x());
  for (std::size_t b = 0; b < xi.size(); ++b) {
    const Vec2 y = xi[b] + eta[b];
    const Vec2 back(c * y.x() + s * y.y(), -s * y.x() + c * y.y());  // R^T y (eq 23)
    const double along = std::abs((back - xi[b]).dot(e1));
    const double across = std::abs(xi[b].dot(e2)), floor = min_sin * xi[b].norm();
    if (floor > 0.0)
      gamma[b] = along / std::max(across, floor);
    else
      gamma[b] = across < kParallel * xi[b].norm() ? 0.0 : along / across;
  }
}

}  // namespace peristat
