// The contact pair law (paper section 3, eqs 12-17; docs/theory/contact.md): one pair of
// particles that hold no bond in, force and Jacobian out. The normal force (paper law, a
// smooth pair law, or the augmented Lagrangian of exact enforcement), Coulomb friction by a
// return map on the tangential slip since the last converged step (eq 14) or against the sign
// of the pseudo-velocity (eq 13), and the consistent Jacobian of both. Pure functions of the
// pair, its history and the law's parameters: no model, no global numbering.
#pragma once

#include <cmath>
#include <cstdint>

#include "core/options.hpp"
#include "core/types.hpp"

namespace peristat {

struct Model;

/// Relative margin for distances computed from lattice coordinates (a partner exactly at
/// the contact radius or on the interface line counts).
inline constexpr double kLatticeRoundOff = 1e-9;

/// State of a pair: open (no force), stick (tangential penalty) or slip (f_c F_n). Pairs of a
/// frictionless scene are open or slip.
enum class PairStatus : std::uint8_t { open = 0, stick = 1, slip = 2 };

/// A candidate pair i < j, fixed for the run (small-sliding assumption: partners are found
/// in the reference configuration, within one horizon).
struct ContactPair {
  Index i = 0, j = 0;
  Vec2 normal = Vec2::Zero();  ///< unit interface normal, oriented so that normal . (X_j - X_i) > 0
  double gap0 = 0.0;           ///< a = normal . (X_j - X_i) > 0, reference normal distance [m]
  double stiffness = 0.0;      ///< C = 3 E_c V_i V_j / (delta^3 t_h) [N], force at unit stretch
  bool from_bond = false;      ///< the faces of a broken bond (ContactSystem::add_broken_bonds)
  /// The unit tangent t = (-n_y, n_x) of the friction law (eq 14).
  Vec2 tangent() const { return {-normal.y(), normal.x()}; }
};

/// The pair law's parameters, shared by all pairs.
struct ContactLaw {
  NormalLaw normal = NormalLaw::paper;
  double radius = 0.0;             ///< delta_c [m]
  double gate = 0.0;               ///< switch-on ramp width as a fraction of delta_c
  double friction = 0.0;           ///< f_c
  double tangential_factor = 1.0;  ///< k_t = tangential_factor * C / a
  /// The paper's eq 13: friction f_c F_n against the sign of the relative tangential
  /// pseudo-velocity (ADR only) instead of the return map.
  bool velocity_sign = false;
  /// Exact enforcement (augmented Lagrangian, docs/theory/contact.md section 8): the normal
  /// force is phi(|t.Y|) max(0, lambda + b C s) (b = PairHistory::boost) for pairs whose reference normal distance is
  /// at most `window`, where phi is 1 while the tangential offset |t.Y| is below
  /// (1 - gate) window and falls linearly to 0 at `window` (the two cells stop overlapping).
  bool exact = false;
  bool stick_multiplier = true;  ///< exact enforcement: stick is a multiplier too (contact.stick)
  /// Exact enforcement: what a pair's closure counts from (contact.closure_reference).
  ClosureReference closure_reference = ClosureReference::spacing;
  /// Exact enforcement where some pairs' closure counts from a shortened by the material's
  /// compressive normal strain at the pair (PairHistory::strain).
  bool material_closure() const { return exact && closure_reference != ClosureReference::spacing; }
  /// Whether pair c's does: the faces of broken bonds (ContactPair::from_bond), or every pair.
  bool strain_reference(const ContactPair& c) const {
    return material_closure() && (closure_reference == ClosureReference::material || c.from_bond);
  }
  double window = 0.0;  ///< one lattice spacing [m]
  /// Coulomb friction with a slip history (friction > 0, not the velocity-sign law).
  bool tracks_slip() const { return friction > 0.0 && !velocity_sign; }
  /// Exact stick (docs/theory/contact.md section 8): under exact enforcement a stuck pair's
  /// tangential force is a multiplier, updated with the normal one until the pair's slip from
  /// its anchor is within the closure tolerance; k_t only sets the rate.
  bool exact_stick() const { return exact && stick_multiplier && tracks_slip(); }
  /// k_t / (C / a): tangential_factor, times the pair's augmentation boost under exact stick
  /// (there k_t is the augmentation's rate, not a compliance).
  double stick_scale(double boost) const { return tangential_factor * (exact_stick() ? boost : 1.0); }
};

/// What a pair remembers between evaluations.
struct PairHistory {
  /// Return-map friction: the anchor w_p the stick force is measured from (the committed
  /// plastic slip; under exact stick the trial anchor of the current multiplier round).
  double slip = 0.0;
  double multiplier = 0.0;           ///< lambda [N], exact enforcement only
  double tangential_velocity = 0.0;  ///< t . (v_j - v_i), velocity-sign friction only
  double boost = 1.0;                ///< augmentation stiffness / C, exact enforcement only
  double tangential_multiplier = 0.0;  ///< mu [N] along t, exact stick only
  /// Exact stick: +-1 when the pair slid at its last update; its multiplier is then +-f_c F at
  /// the current normal force F (it stays at the limit while F changes), and
  /// tangential_multiplier is unused.
  double limit_sign = 0.0;
  /// Exact enforcement with ContactLaw::material_closure(): the material's normal strain at the
  /// pair, min(0, n.E.n) (lagged: set at the multiplier updates); the closure is s + strain.
  double strain = 0.0;
};

/// Output of the pair kernel. g is the pair's internal force dPi/d(u_j - u_i): the force on
/// particle j is -g, on particle i it is +g. J = dg/d(u_j - u_i) (not symmetric in slip).
struct PairResult {
  PairStatus status = PairStatus::open;
  double normal_force = 0.0;  ///< F_n >= 0 [N]
  double tangential = 0.0;    ///< tau [N] along t = (-n_y, n_x): force on j is -tau t
  Vec2 g = Vec2::Zero();
  Mat2 J = Mat2::Zero();
};

/// The pair kernel, a pure function. `X` = X_j - X_i, `du` = u_j - u_i.
PairResult contact_pair(const ContactPair& pair, const Vec2& X, const Vec2& du, const PairHistory& history,
                        const ContactLaw& law, bool want_jacobian);

/// The stiffness of a closed pair at full gate along its interface normal, (normal_scale C/a)
/// n n^T, plus (stick_scale C/a) t t^T when it sticks: the preconditioner's block of a pair in
/// contact and the predictor's Jacobian of a touching one (normal_scale: the augmentation
/// boost, 1 under penalty, 0 when the law's normal term lies elsewhere; stick_scale:
/// ContactLaw::stick_scale).
Mat2 closed_pair_block(const ContactPair& pair, double normal_scale, double stick_scale, bool stick);

/// ContactSystem::set_touching_closed(): an open pair that touches gets the stiffness of a
/// closed pair at full gate, stuck when the law has friction; its force stays zero.
void close_if_touching(const ContactPair& pair, const Vec2& X, const Vec2& du, double boost, const ContactLaw& law,
                       PairResult& out);

/// The pair stiffness of eq 17, C = 3 E_c V_i V_j / (delta^3 t_h), of two particles of a model
/// (E_c from the two bodies' materials, or contact.stiffness when the scene gives one).
class PairStiffness {
 public:
  /// `modulus_override`: contact.stiffness (0: eq 17); `exact`: exact enforcement.
  PairStiffness(const Model& model, double modulus_override, bool exact);
  /// C of a candidate pair: from contact.stiffness (eq 17 modulus when 0) under penalty, from eq 17
  /// under exact enforcement (where contact.stiffness sets the augmentation's start).
  double operator()(Index i, Index j) const;
  /// C with the contact modulus `modulus_override` (eq 17 when 0).
  double with_modulus(Index i, Index j, double modulus_override) const;
  double modulus_override() const { return m_modulus_override; }

 private:
  const Model& m_model;
  double m_delta3 = 0.0;
  double m_modulus_override = 0.0;  ///< contact.stiffness (0: eq 17)
  bool m_exact = false;
};

/// The signed normal distance n.Y of a pair and its tangential offset t.Y, Y = X + du.
struct PairGap {
  double normal = 0.0, tangential = 0.0;
};
inline PairGap pair_gap(const ContactPair& pair, const Vec2& X, const Vec2& du) {
  const Vec2 Y = X + du;
  return {pair.normal.dot(Y), pair.tangent().dot(Y)};
}
/// Exact enforcement: the window phi of a facing pair at tangential offset |t.Y| =
/// `offset` (ContactLaw::exact), 1 up to (1 - gate) window, then linear to 0 at the window;
/// `slope` gets dphi/d|t.Y| (0 off the ramp).
inline double window_weight(double offset, const ContactLaw& law, double* slope = nullptr) {
  if (slope) *slope = 0.0;
  if (offset >= law.window) return 0.0;
  if (law.gate <= 0.0) return 1.0;
  const double width = law.gate * law.window, rho = (law.window - offset) / width;
  if (rho >= 1.0) return 1.0;
  if (slope) *slope = -1.0 / width;
  return rho;
}

/// A pair has crossed when its particles have passed each other along the normal while
/// facing each other: n.Y < 0 with |t.Y| below one spacing (their cells overlap).
inline bool crossed(const PairGap& g, double spacing) {
  return g.normal < 0.0 && std::abs(g.tangential) < spacing;
}

}  // namespace peristat
