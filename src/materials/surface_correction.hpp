// Surface correction of the OSB families (docs/theory/osb.md, section 8): a particle near
// a free edge, a pre-crack or a broken face misses part of its family, and with it part of
// the material. The correction gives each bond of a family an influence factor omega_b
// (the kernel's weight becomes omega_b w_b, its weighted volume the interior one), chosen
// once per family change, never per iteration. omega is fixed while Newton iterates, so the
// energy stays one smooth function of u and the tangent stays exact.
//   none:    omega = 1 and m_i of the family as built (the paper's model).
//   moments: omega_b = 1 + q(n_b) . lambda_i, q(n) = the five quartic monomials of the bond
//            direction, with lambda_i such that the family's fourth moment
//            sum omega w x^2 n n n n equals the interior one, and omega closest to 1 in
//            sum w x^2 (omega - 1)^2, within [kMinInfluence, kMaxInfluence]. Then W_i is the
//            interior energy density for every homogeneous deformation (dilatation and
//            deviatoric part alike).
#pragma once

#include <array>
#include <span>
#include <vector>

#include "discretisation/model.hpp"

namespace peristat {

/// Bounds of the moments method's influence factors: positive weights keep every family's
/// energy convex; the upper bound keeps a corner particle from leaning on one or two bonds.
inline constexpr double kMinInfluence = 0.2;
inline constexpr double kMaxInfluence = 5.0;

/// What one computation of the factors found (for the run summary and the tests): the
/// construction's, or the last update's after bonds broke.
struct SurfaceCorrectionStats {
  Index families = 0;          ///< families computed
  Index corrected = 0;         ///< families cut (not every stencil bond intact): factors computed
  Index clipped = 0;           ///< families with a factor at a bound
  Index unmatched = 0;         ///< families whose fourth moment could not be matched to 1e-6
  double min_influence = 1.0;  ///< smallest and largest factor over the families computed
  double max_influence = 1.0;
  double seconds = 0.0;
};

class SurfaceCorrection {
 public:
  /// Factors of every family from the model's bond weights (pre-cracks already cut). The
  /// stats count the families of the particles `counted` names (empty: every one; a rank of a
  /// distributed run counts its own, so that the sum over the ranks counts each family once).
  SurfaceCorrection(const Model& model, SurfaceCorrectionMethod method, std::vector<char> counted = {});

  /// Recomputes the families of `particles` from `intact` (per bond, 0 when broken; empty: the
  /// model's weights, every bond intact). Under
  /// `none` the families keep the weighted volume they were built with (bond breaking then
  /// softens a particle, as in the paper).
  void update(std::span<const double> intact, std::span<const Index> particles);
  /// Recomputes every family.
  void update_all(std::span<const double> intact);

  SurfaceCorrectionMethod method() const { return m_method; }
  /// The kernel's inputs: per bond of particle i's family omega_b w_b (0 when broken), per
  /// particle m. A family whose weights are the model's (every factor 1, every bond intact: the
  /// interior) reads the model's bond weights; the others keep their own (8 bytes per bond
  /// fewer over the interior).
  std::span<const double> family_weights(Index i) const {
    const Index nb = m_model.bonds.family_size(i);
    const std::size_t k = static_cast<std::size_t>(i);
    return m_shared[k] ? m_model.bonds.weights(i) : std::span<const double>(m_own).subspan(m_offset[k], nb);
  }
  /// Bond b's weight, b one of particle i's bonds.
  double weight(Index i, Index b) const { return family_weights(i)[b - m_model.bonds.start[i]]; }
  /// Every bond's weight in bond order (tests and diagnostics: it allocates 8 bytes per bond).
  std::vector<double> bond_weights() const;
  /// Families that keep their own weights (cut by a surface, a crack or broken bonds).
  Index own_families() const;
  std::span<const double> weighted_volume() const { return m_volume; }
  /// The interior weighted volume m0.
  double interior_volume() const { return m_m0; }
  const SurfaceCorrectionStats& stats() const { return m_stats; }
  std::size_t memory_bytes() const;

 private:
  /// Family i's weights from `all_intact` (update()'s `intact`) into `w` (its size).
  void compute_family(Index i, std::span<const double> all_intact, std::span<double> w,
                      SurfaceCorrectionStats& stats);

  const Model& m_model;
  SurfaceCorrectionMethod m_method;
  double m_m0 = 0.0;
  std::array<double, 5> m_q0{};  ///< interior fourth moment sum w x^2 q(n) (xxxx, xxxy, xxyy, xyyy, yyyy)
  std::vector<char> m_shared;    ///< per particle: 1 when its family's weights are the model's
  std::vector<Index> m_offset;   ///< per particle: the start of its own weights in m_own, or -1
  std::vector<double> m_own;     ///< the weights of the families that do not share the model's
  std::vector<double> m_volume;  ///< per particle
  SurfaceCorrectionStats m_stats;
  std::vector<char> m_counted;  ///< per particle, or empty: every family counts in m_stats
};

/// The five quartic monomials of a unit direction n: (c^4, c^3 s, c^2 s^2, c s^3, s^4).
std::array<double, 5> quartic_monomials(const Vec2& n);

}  // namespace peristat
