#include "materials/osb.hpp"

#include <cmath>
#include <vector>

namespace peristat {

OsbConstants OsbConstants::from(const Material& material) {
  const double E = material.E, nu = material.nu;
  OsbConstants k;
  k.mu = shear_modulus(material);
  const double bulk = E / (3.0 * (1.0 - 2.0 * nu));
  // eq 8: k' = k + mu (nu + 1)^2 / (9 (2 nu - 1)^2)
  k.k_prime = bulk + k.mu * (nu + 1.0) * (nu + 1.0) / (9.0 * (2.0 * nu - 1.0) * (2.0 * nu - 1.0));
  // eq 3: theta = 2 (2 nu - 1) / (nu - 1) * (omega x . e) / m
  k.c = 2.0 * (2.0 * nu - 1.0) / (nu - 1.0);
  k.kinematics = material.kinematics;
  return k;
}

double weighted_volume(std::span<const Vec2> xi, std::span<const double> weight) {
  double m = 0.0;
  for (std::size_t b = 0; b < xi.size(); ++b) m += xi[b].squaredNorm() * weight[b];
  return m;
}

FamilyResult osb_family(const OsbConstants& material, double m, std::span<const Vec2> xi,
                        std::span<const double> weight, std::span<const Vec2> eta, const FamilyOutputs& out,
                        bool want_tangent) {
  FamilyResult result;
  const std::size_t n = xi.size();
  if (n == 0 || m <= 0.0) {
    return result;  // an isolated particle carries no bond energy
  }
  const bool finite = material.kinematics == Kinematics::finite;
  const bool forces = !out.force.empty();      // the caller may take the law alone (no tangent)
  const double alpha = 8.0 * material.mu / m;  // eq 8
  const double cm = material.c / m;

  // Pass 1: extensions, directions (kept in force until pass 3), dilatation (eq 3).
  double sum_bxe = 0.0;
  double sum_bxx = 0.0;  // sum w x^2: m itself until bonds break (m stays at its reference value)
  // |xi_b| for passes 2 and 3 (one square root per bond instead of up to three): the calling
  // thread's buffer, grown to the largest family once.
  thread_local std::vector<double> lengths;
  if (lengths.size() < n) lengths.resize(n);
  for (std::size_t b = 0; b < n; ++b) {
    const BondKinematics k = bond_kinematics(finite, xi[b], eta[b]);
    lengths[b] = k.x;
    sum_bxx += weight[b] * k.x * k.x;
    if (forces) out.force[b] = k.M;
    out.extension[b] = k.e;
    sum_bxe += weight[b] * k.x * k.e;
  }
  const double theta = cm * sum_bxe;

  // Pass 2: deviatoric extensions (eq 6) and (omega e^d) . x.
  double sum_bxed = 0.0, sum_ed2 = 0.0;
  for (std::size_t b = 0; b < n; ++b) {
    const double x = lengths[b];
    const double ed = out.extension[b] - theta * x / 3.0;
    sum_bxed += weight[b] * x * ed;
    sum_ed2 += weight[b] * ed * ed;
  }
  result.theta = theta;
  result.energy_density = 0.5 * material.k_prime * theta * theta + 0.5 * alpha * sum_ed2;  // eq 5

  // Pass 3: force state (eqs 9-10), dW/de_b = w_b [c (k' theta - alpha/3 (omega e^d).x) x / m
  // + alpha e^d_b], and on request the tangent pieces.
  const BondForceLaw law{cm * (material.k_prime * theta - alpha / 3.0 * sum_bxed), alpha, theta};
  result.law = law;
  // d2W/de de = diag(alpha w) + beta (w x)(w x)^T; the m here is the sum over the intact
  // bonds, which differs from the weighted volume m once bonds are broken.
  result.beta = cm * cm * (material.k_prime + alpha * sum_bxx / 9.0) - 2.0 * alpha * cm / 3.0;
  if (!forces && !want_tangent) return result;
  for (std::size_t b = 0; b < n; ++b) {
    const double x = lengths[b];
    const double e = out.extension[b];
    const double t = law.t(weight[b], x, e);
    const Vec2 M = out.force[b];
    out.force[b] = t * M;
    if (!want_tangent) continue;
    out.s[b] = weight[b] * x * M;
    // Geometric part (finite): t/y (I - M M^T), y = |xi + eta| = x + e.
    out.k_bond[b] = BondStiffness{alpha * weight[b], finite ? t / (x + e) : 0.0};
  }
  return result;
}

}  // namespace peristat
