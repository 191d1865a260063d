#include "core/k_field.hpp"

#include <cmath>
#include <numbers>

namespace peristat {

Vec2 KField::at(const Vec2& X) const {
  const Vec2 n(-direction.y(), direction.x());
  const Vec2 d = X - tip;
  const double a = d.dot(direction), b = d.dot(n);
  const double r = std::hypot(a, b), phi = std::atan2(b, a);
  const double f = std::sqrt(r / (2.0 * std::numbers::pi)) / (2.0 * mu);
  const double c = std::cos(phi / 2), s = std::sin(phi / 2);
  const double ut = f * (K_I * c * (kappa - 1.0 + 2.0 * s * s) + K_II * s * (kappa + 1.0 + 2.0 * c * c));
  const double un = f * (K_I * s * (kappa + 1.0 - 2.0 * c * c) - K_II * c * (kappa - 1.0 - 2.0 * s * s));
  return ut * direction + un * n;
}

}  // namespace peristat
