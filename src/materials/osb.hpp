// Plane-stress ordinary state-based peridynamics (Le et al. 2014; paper eqs 3-10) as a
// family kernel: one particle's bonds in, energy density, force state and tangent out.
// No global numbering, no options. Derivations: docs/theory/osb.md.
#pragma once

#include <span>

#include "core/description.hpp"
#include "core/types.hpp"
#include "materials/family_kernel.hpp"

namespace peristat {

/// Material constants of eqs 3 and 8, influence function omega = 1.
struct OsbConstants {
  double k_prime = 0.0;  ///< k' = k + mu (nu+1)^2 / (9 (2nu-1)^2), k = E / (3 (1 - 2nu))
  double mu = 0.0;       ///< shear modulus E / (2 (1 + nu)); alpha = 8 mu / m
  double c = 0.0;        ///< dilatation factor 2 (2nu - 1) / (nu - 1) of eq 3
  Kinematics kinematics = Kinematics::finite;

  static OsbConstants from(const Material& material);
};

/// The shear modulus mu = E / (2 (1 + nu)).
inline double shear_modulus(const Material& material) {
  return material.E / (2.0 * (1.0 + material.nu));
}

/// The plane-stress bulk modulus kappa = E / (2 (1 - nu)) (docs/theory/failure.md, "Critical stretch").
inline double bulk_modulus_2d(const Material& material) {
  return material.E / (2.0 * (1.0 - material.nu));
}

/// Evaluates one family. Inputs: reference bond vectors xi, quadrature weights w (area),
/// relative displacements eta_b = u_j - u_i, weighted volume m. When want_tangent is false
/// only the forces t_b M_b and the extensions are written, and with an empty out.force only
/// the extensions (the result's law gives the forces).
///
/// Energy W(e) = k' theta^2 / 2 + alpha/2 sum_b omega w_b (e_b - theta |xi_b| / 3)^2 with
/// theta = (c / m) sum_b omega w_b |xi_b| e_b, e_b = |xi_b + eta_b| - |xi_b| (finite) or
/// M0_b . eta_b (small). Its Hessian in the extensions is
///   d2W / de_a de_b = alpha omega w_a delta_ab + beta b_a b_b,
///   beta = (c/m)^2 (k' + alpha m / 9) - 2 alpha c / (3 m),
/// so the tangent with respect to eta_a, eta_b is delta_ab k_bond_a + beta s_a s_b^T.
FamilyResult osb_family(const OsbConstants& material, double m, std::span<const Vec2> xi,
                        std::span<const double> weight, std::span<const Vec2> eta, const FamilyOutputs& out,
                        bool want_tangent);

/// The OSB model behind the FamilyKernel seam (materials/family_kernel.hpp).
class OsbKernel final : public FamilyKernel {
 public:
  explicit OsbKernel(const Material& material)
      : m_constants(OsbConstants::from(material)), m_modulus(material.E) {}
  FamilyResult evaluate(double m, std::span<const Vec2> xi, std::span<const double> weight,
                        std::span<const Vec2> eta, const FamilyOutputs& out,
                        bool want_tangent) const override {
    return osb_family(m_constants, m, xi, weight, eta, out, want_tangent);
  }
  bool constant_tangent() const override { return m_constants.kinematics == Kinematics::small; }
  bool finite_kinematics() const override { return m_constants.kinematics == Kinematics::finite; }
  double modulus() const override { return m_modulus; }

 private:
  OsbConstants m_constants;
  double m_modulus;  ///< E
};

}  // namespace peristat
