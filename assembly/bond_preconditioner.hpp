// The `bond` preconditioner matrix of factor-preconditioned Krylov solves
// (docs/theory/newton.md, "Bond preconditioner"): the material bond part of the OSB tangent
// on a short stencil, without the rank-one dilatation coupling, plus the normal (and stick)
// stiffness of every contact pair in contact. Symmetric positive semi-definite bond by bond.
#pragma once

#include <memory>
#include <span>
#include <vector>

#include "assembly/pattern.hpp"
#include "contact/contact.hpp"
#include "core/options.hpp"
#include "discretisation/model.hpp"
#include "materials/family_kernel.hpp"
#include "materials/surface_correction.hpp"

namespace peristat {

class BondPreconditioner {
 public:
  /// `contact`: its candidate pairs join the pattern and their blocks the values (null
  /// without contact); it must outlive the preconditioner. `weights`: the bond weights its
  /// alpha' is measured with (the kernel's, so surface-corrected families are not counted
  /// twice: a family's missing bonds raise its factors, not also its alpha'); null: the
  /// model's.
  /// `owned`: the rows this rank assembles (build_pattern()); every row by default.
  BondPreconditioner(const Model& model, const BondPreconditionerOptions& options,
                     const ContactSystem* contact, const SurfaceCorrection* weights,
                     const OwnedRows& owned = {});

  /// A matrix with the preconditioner's pattern and zero values.
  SparseMatrix make_matrix() const { return m_pattern.make_matrix(m_model.constraints); }

  /// P = sum over bonds b = i -> j with |xi_b| <= bond_radius dx of V_i alpha'_i omega w_b
  /// (g_b g_b^T), g_b the gradient of the extension along the current direction M_b,
  /// alpha' = 8 mu / m' with m' the weighted volume of those bonds (so the short stencil
  /// keeps the long-wave stiffness), plus each contact pair's preconditioner block.
  /// `weights`: the kernel's bond weights; `s`: s_b = b_b M_b of the last evaluation with a
  /// tangent (FamilyOutputs), whose direction M_b is: s_b / |s_b|, else -s_r / |s_r| from the
  /// reverse bond r (M_r = -M_b), else (no weight either way, or no tangent yet) xi_b / |xi_b|.
  void assemble(SparseMatrix& P, const SurfaceCorrection& weights, const BondVectors& s) const;

  std::size_t memory_bytes() const;

 private:
  const Model& m_model;
  const ContactSystem* m_contact;      ///< null without contact
  double m_radius;                     ///< [m]
  TangentPattern m_pattern;            ///< bonds within m_radius, plus contact candidates
  std::vector<double> m_alpha_volume;  ///< per particle V 8 mu / m'
};

}  // namespace peristat
