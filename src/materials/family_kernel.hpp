// The seam between the assembler and a constitutive model: one particle's bond family in,
// energy density, per-bond force scalars and directions, and the tangent pieces out
// (docs/theory/osb.md, section 3: the tangent of a family is diag(k_b) + beta s s^T in the
// bonds' relative displacements; a bond-based model has beta = 0). No global numbering, no
// options. A new material is one kernel file and one line in make_family_kernel().
#pragma once

#include <array>
#include <memory>
#include <span>

#include "core/description.hpp"
#include "core/types.hpp"

namespace peristat {

/// Symmetric 2x2 block stored as (xx, xy, yy).
using Sym2 = std::array<double, 3>;

/// A bond's stiffness k_b = axial M M^T + transverse (I - M M^T), stored as (axial,
/// transverse): a central force t M has no other form, and M is s_b's direction, kept
/// already (8 bytes per bond less than a Sym2).
using BondStiffness = std::array<double, 2>;

/// A bond's s_b or stiffness pair in single precision: the matrix-free action's factors with
/// solver.krylov.factors float (16 bytes per bond instead of 32; the kernels compute in
/// double, and the assembler rounds what it keeps).
using Float2 = std::array<float, 2>;

/// A kept pair of floats as doubles (exact).
inline Vec2 widened(const Float2& v) {
  return Vec2(double(v[0]), double(v[1]));
}

/// Each bond's s_b = b_b M_b of the last evaluation with a tangent, kept in double or in
/// single precision (exactly one of the two spans holds the bonds).
struct BondVectors {
  std::span<const Vec2> full;
  std::span<const Float2> single;
  Vec2 operator[](std::size_t b) const { return single.empty() ? full[b] : widened(single[b]); }
};

/// k_b as a block, its direction M_b = s_b / |s_b| (FamilyOutputs::s); a bond without weight
/// (s_b = 0, broken) has no stiffness.
inline Sym2 bond_block(const BondStiffness& k, const Vec2& s) {
  const double ss = s.squaredNorm();
  if (ss == 0.0) return Sym2{k[1], 0.0, k[1]};
  const double c = (k[0] - k[1]) / ss;
  return Sym2{k[1] + c * s.x() * s.x(), c * s.x() * s.y(), k[1] + c * s.y() * s.y()};
}

/// A bond's current unit direction M, reference length x = |xi| and extension e, from its
/// reference vector xi and relative displacement eta. Finite kinematics: M = y / |y|, y = xi +
/// eta, e = |y| - |xi| written as (|y|^2 - |xi|^2) / (|y| + |xi|), without the cancellation
/// that at strains of 1e-6 would lose ten digits and put a floor under the residual. Small:
/// M = xi / |xi|, e = M . eta. The reverse bond (-xi, -eta) gets -M and the same x and e, bit
/// for bit: negation is exact.
struct BondKinematics {
  Vec2 M;
  double x = 0.0;
  double e = 0.0;
};
inline BondKinematics bond_kinematics(bool finite, const Vec2& xi, const Vec2& eta) {
  BondKinematics k;
  k.x = xi.norm();
  if (finite) {
    const Vec2 y = xi + eta;
    const double ylen = y.norm();
    k.M = y / ylen;
    k.e = (2.0 * xi.dot(eta) + eta.squaredNorm()) / (ylen + k.x);
  } else {
    k.M = xi / k.x;
    k.e = k.M.dot(eta);
  }
  return k;
}

/// A family's force state as a law of one bond's extension (eqs 9-10):
///   t_b = w_b (p |xi_b| + alpha e^d_b),  e^d_b = e_b - theta |xi_b| / 3,
/// with per-family p, alpha and the dilatation theta (a bond-based model: p = theta = 0). The
/// family's kernel evaluates its bonds with it, and the force gather evaluates a neighbour's
/// bond with it again instead of keeping t_b M_b for every bond (16 bytes per bond fewer): the
/// same operations give the same bits. A kernel whose bond force is not of this form (one
/// with per-bond history, say) needs its forces kept per bond again.
struct BondForceLaw {
  double p = 0.0;
  double alpha = 0.0;
  double theta = 0.0;
  double t(double w, double x, double e) const {
    const double ed = e - theta * x / 3.0;
    return w * (p * x + alpha * ed);
  }
};

/// Outputs of one family, written into caller-owned arrays of the family's size. M_b is the
/// unit current bond direction (the reference one if small) and t_b = dW/de_b the scalar force
/// state times the bond weight [Pa m^2 / m]; the bond force t_b M_b as one vector (the
/// assembler keeps s_b and k_bond per bond, and evaluates forces again from FamilyResult::law).
struct FamilyOutputs {
  std::span<Vec2> force;        ///< t_b M_b; may be empty without a tangent (the law alone)
  std::span<double> extension;  ///< e_b = |xi_b + eta_b| - |xi_b| (the kernel's scratch too)
  std::span<Vec2> s;  ///< b_b M_b with b_b = omega w_b |xi_b| (rank-one vectors); with a tangent only
  /// (alpha omega w_b, t_b / y_b): alpha omega w_b M M^T + (t_b / y_b)(I - M M^T), the second
  /// term finite kinematics' only (0 if small); with a tangent only (may be empty without)
  std::span<BondStiffness> k_bond;
};

struct FamilyResult {
  double energy_density = 0.0;  ///< W (eq 5) [J/m^3]
  double theta = 0.0;           ///< dilatation (eq 3)
  double beta = 0.0;            ///< coefficient of the rank-one tangent term
  BondForceLaw law;             ///< t_b as a function of the bond's extension (0 if isolated)
};

/// Weighted volume m = sum omega |xi|^2 w (eq 4), over the bonds given.
double weighted_volume(std::span<const Vec2> xi, std::span<const double> weight);

class FamilyKernel {
 public:
  virtual ~FamilyKernel() = default;
  /// Evaluates one family: reference bond vectors xi, quadrature weights w (0 for a broken
  /// bond), relative displacements eta_b = u_j - u_i, weighted volume m of the intact
  /// reference family. When want_tangent is false only force and extension are written, and
  /// with an empty out.force only extension (the caller takes FamilyResult::law alone).
  virtual FamilyResult evaluate(double m, std::span<const Vec2> xi, std::span<const double> weight,
                                std::span<const Vec2> eta, const FamilyOutputs& out,
                                bool want_tangent) const = 0;
  /// True when the tangent does not depend on the displacement (linearised kinematics).
  virtual bool constant_tangent() const = 0;
  /// True with finite kinematics (bond_kinematics()' first argument).
  virtual bool finite_kinematics() const = 0;
  /// The material's stiffness scale [Pa] (Young's modulus): a family's volume times it is the
  /// energy scale of its round-off (the energy balance's tolerance, assembly/energy_balance.hpp).
  virtual double modulus() const = 0;
};

/// The kernel of a body's material (the registry: today every material is plane-stress OSB).
std::unique_ptr<FamilyKernel> make_family_kernel(const Material& material);

}  // namespace peristat
