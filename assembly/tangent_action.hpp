// The matrix-free action of the tangent (solver.linear: matrix_free): y = K v from the
// families' factored Hessians and the contact pairs' Jacobians without forming K
// (docs/theory/newton.md, "Matrix-free"; docs/theory/osb.md, "Assembly").
#pragma once

#include <cstddef>
#include <span>
#include <vector>

#include "assembly/bookkeeping.hpp"
#include "assembly/pattern.hpp"
#include "contact/contact.hpp"
#include "core/types.hpp"
#include "discretisation/model.hpp"
#include "materials/family_kernel.hpp"

namespace peristat {

/// apply_tangent()'s schedule: chunks of `chunk` consecutive particles (chunk c holds
/// c * chunk ..), grouped by colour so that the families of two chunks of one colour never
/// write the same row of the product. Depends on the particles alone: the same on every rank
/// and for any number of threads. Throws std::logic_error if a bond is longer than the stencil.
std::vector<std::vector<Index>> chunk_colours(const Model& model, Index chunk);

/// Distributed: the unknowns (ascending) whose entries of v the action of this rank's rows
/// reads: the ghosts of its rows, two horizons deep, with contact partners and mirror
/// sources. Every unknown when `rows` is all().
std::vector<Index> action_reads(const Model& model, const OwnedRows& rows, const ContactSystem* contact);

/// The families' factored Hessians of the last evaluation with a tangent, as the assembler
/// caches them (FamilyOutputs): per bond s_b and k_b (axial, transverse), per particle
/// s_self = -sum_b s_b and beta_i V_i. prepare() turns kbond into the pairs' stiffnesses in
/// the action's form: entry b holds (c_b, g) with V_i k_b + V_j k_r = g I + c_b s_b s_b^T
/// (= g I + c_r s_r s_r^T: s_r is -s_b's direction). The per-bond factors in double (s,
/// kbond) or, with solver.krylov.factors float, in single precision (s32, kbond32): exactly
/// one pair holds the bonds, `single` says which; s_self sums the kept (rounded) s_b, so that
/// a rigid translation has no action either way. In single precision each family's s_b are
/// kept divided by a power of two sigma_i (O(1) values at any spacing), s_self alike, and
/// beta_volume holds beta_i V_i sigma_i^2: the products are the same (QuasiStaticProblem::
/// keep_factors()).
struct FamilyHessians {
  std::span<const Vec2> s;
  std::span<BondStiffness> kbond;
  std::span<const Float2> s32;
  std::span<Float2> kbond32;
  bool single = false;
  std::span<const Vec2> s_self;
  std::span<const double> beta_volume;
};

/// The product's schedule and scratch, and what it keeps of the last evaluation with a tangent
/// (the pairs' Jacobians, the fragments' diagonal). Empty unless built matrix-free.
class TangentAction {
 public:
  /// matrix_free false: no schedule (apply() throws).
  TangentAction(const Model& model, bool matrix_free);

  /// Tests: chunks of consecutive families (default: 1024, or a 128th of the particles when
  /// that is more).
  void set_chunk(Index chunk);
  /// After an evaluation with a tangent: turns h.kbond into the pairs' stiffnesses
  /// (pair_stiffness()), keeps the contact pairs' Jacobians (a residual-only evaluation
  /// recomputes the pairs without them, and the product must stay the tangent's) and, with
  /// fragments, the largest diagonal entry of K over the unknowns (their diagonal).
  /// `families` false: h's factors are those of the last prepare() (linearised kinematics,
  /// the same bonds), already turned into the pairs' stiffnesses; the pairs' Jacobians and the
  /// fragments' diagonal are taken again.
  void prepare(const FamilyHessians& h, const ContactSystem* contact, bool fragments, bool families = true);
  /// prepare()'s work on h.kbond alone, for factors computed again at the same state
  /// (QuasiStaticProblem::resume_action()): the pairs' Jacobians and the fragments' diagonal
  /// it kept stay.
  void prepare_families(const FamilyHessians& h);
  /// f = H u over every component at the full displacement u (every particle's rows), from the
  /// factors prepare() saw, without the contact pairs and the fragments' decoupling: with
  /// linearised kinematics the bonds' internal force dPi/du, which is linear in u and zero at
  /// u = 0 (QuasiStaticProblem::evaluate()). A whole model's; f is resized to 2N.
  void bond_forces(const FamilyHessians& h, const OwnedRows& rows, const VectorXd& u, VectorXd& f);
  /// y = K v with K the tangent prepare() saw; the fragments' unknowns decoupled (zero row
  /// and column, the diagonal of prepare()). With `share` (distributed: rows a part), only
  /// this rank's rows of y, bit for bit the whole product's; the other rows are zero.
  void apply(const FamilyHessians& h, const ContactSystem* contact, const OwnedRows& rows, const RankShare* share,
             const std::vector<Index>& fragment_unknowns, const VectorXd& v, VectorXd& y);
  std::size_t memory_bytes() const;
  /// With `on`, apply() reads a single-precision copy of double factors (16 bytes per bond
  /// besides their 32), made by prepare() and prepare_families(), while bond_forces() reads
  /// the doubles: the Krylov iterations read half the factor bytes, the residual keeps double
  /// precision (solver.krylov.factors `mixed`). Nothing with single-precision factors.
  void set_float_copy(bool on);
  /// Frees the copy (the factors are dropped while a preconditioner is set up); the next
  /// prepare() or prepare_families() makes it again.
  void release_float_copy();
  /// The float copy of the families `families` made again from h (QuasiStaticProblem::
  /// patch_factors(): the factors of those families or of their pairs changed); all of it
  /// when there is none yet. Nothing without a copy.
  void patch_float_copy(const FamilyHessians& h, std::span<const Index> families);

  /// A pair's stiffnesses in the action's form (FamilyHessians) from its two bonds' kernel
  /// factors: b the lower bond index, in family q (volume V_q), r its reverse (V_j); |s_b|^2
  /// and |s_r|^2. c_b for b, c_r for r, and their common g.
  struct PairForm {
    double c_lower, c_upper, g;
  };
  static PairForm pair_form(double Vq, double Vj, const Vec2& kb, const Vec2& kr, double sb, double sr) {
    // V_q k_b + V_j k_r = g I + (a - g) M M^T, M M^T = s_b s_b^T / |s_b|^2 = s_r s_r^T / |s_r|^2.
    const double a = Vq * kb[0] + Vj * kr[0], g = Vq * kb[1] + Vj * kr[1];
    return {sb > 0.0 ? (a - g) / sb : 0.0, sr > 0.0 ? (a - g) / sr : 0.0, g};
  }

 private:
  /// make_float_copy()'s work on the family of particle i.
  void copy_family(const FamilyHessians& h, Index i);
  /// The float copy of h's double factors, scaled by each family's power of two as
  /// QuasiStaticProblem::keep_factors() scales single-precision ones: s_b / sigma_i rounded,
  /// s_self the sum of the rounded s_b (no action on a rigid translation), the pair
  /// coefficient c_b |s_b|^2 / |s_b rounded|^2 (the same (a - g)), beta_i V_i sigma_i^2.
  void make_float_copy(const FamilyHessians& h);
  /// The copy as FamilyHessians (single), for multiply().
  FamilyHessians float_copy();
  /// m_y_full += H m_v_full over the families and contact pairs (with `share`, those of this
  /// rank's rows), colour by colour.
  void multiply(const FamilyHessians& h, const ContactSystem* contact, const OwnedRows& rows, const RankShare* share);
  /// multiply() on the factors' scalar type T (double or float), s and k as T pairs per bond.
  template <class T>
  void multiply_on(const T* s, const T* k, const FamilyHessians& h, const ContactSystem* contact,
                   const OwnedRows& rows, const RankShare* share);
  /// Turns h.kbond into the pairs' stiffnesses (V_i k_b + V_j k_r, FamilyHessians), so that
  /// apply() reads each pair's term from one family (the lower index's), with the s_b it
  /// reads already.
  void pair_stiffness(const FamilyHessians& h) const;
  template <class S, class K>
  void pair_stiffness_on(std::span<const S> s, std::span<K> kbond) const;
  /// The largest diagonal entry of K over the unknowns (the fragments' diagonal), from the
  /// factored Hessians (mirror ghosts' folds not included: it only sets a scale).
  double tangent_diagonal_max(const FamilyHessians& h, const ContactSystem* contact) const;
  template <class S, class K>
  double tangent_diagonal_max_on(std::span<const S> s, std::span<const K> kbond, const FamilyHessians& h,
                                 const ContactSystem* contact) const;

  const Model& m_model;
  /// apply()'s schedule, chunks of m_chunk consecutive families by colour (chunks of one
  /// colour write disjoint rows).
  Index m_chunk = 0;
  std::vector<std::vector<Index>> m_colours;
  /// The contact pairs' Jacobians of the last evaluation with a tangent.
  std::vector<Mat2> m_pair_jacobian;
  double m_fragment_diagonal = 0.0;
  VectorXd m_v_free, m_v_full, m_y_full;  ///< scratch (allocated once)
  bool m_float_copy = false;              ///< set_float_copy()
  bool m_have_copy = false;               ///< the copy holds the factors prepare() saw
  std::vector<Float2> m_s32, m_k32;       ///< per bond: s_b / sigma_i, (c_b sigma_i^2, g)
  std::vector<Vec2> m_s_self32;           ///< per particle: -sum_b of the rounded s_b
  std::vector<double> m_beta_volume32;    ///< per particle: beta_i V_i sigma_i^2
};

}  // namespace peristat
