// Bond failure criteria of issue 5 (paper section 4.4, eqs 19-23; docs/theory/failure.md):
// critical stretch from the critical energy release rate, and the critical bond skew of
// Zhang and Qiao (2019) for shear-driven cracks. Pure functions of one family's bonds;
// BondFailure (materials/bond_failure.hpp) holds the state that uses them, and the
// quasi-static breaking loop is break_and_resolve in solvers/load_stepping.cpp.
#pragma once

#include <span>

#include "core/types.hpp"

namespace peristat {

/// Critical stretch of 2D (plane) ordinary state-based peridynamics, Madenci and Oterkus
/// (2014): s_c = sqrt(G_c / ((6 mu / pi + 16 (kappa - 2 mu) / (9 pi^2)) delta)), with kappa
/// the 2D bulk modulus and mu the shear modulus.
double critical_stretch(double G_c, double kappa, double mu, double delta);

/// Critical skew, paper eq 19 (Zhang and Qiao 2019): gamma_c = sqrt(75 pi G_c / (64 mu delta)).
double critical_skew(double G_c, double mu, double delta);

/// Closed-crack LEFM (docs/theory/failure.md, "A closed crack in compression"): a straight
/// crack of length 2a whose normal makes the angle theta [rad] with a uniaxial compression
/// sigma, faces closed with Coulomb friction f_c. The effective shear on the faces is
/// tau_eff = sigma (sin theta cos theta - f_c cos^2 theta), K_II = tau_eff sqrt(pi a), and
/// in-plane (mode II) growth starts at K_II = sqrt(E G_c) (plane stress):
///   sigma_c = sqrt(E G_c / (pi a)) / (sin theta cos theta - f_c cos^2 theta).
/// +infinity when friction holds the faces (sin theta cos theta <= f_c cos^2 theta).
double closed_crack_start_stress(double E, double G_c, double a, double theta, double f_c);

/// Stretch |xi + eta| / |xi| - 1 of a bond.
double bond_stretch(const Vec2& xi, const Vec2& eta);

/// The reference bond of a family for the skew: the bond whose direction is closest to
/// `direction` (either sense), the shortest among equally close ones, the first in the
/// family's order among equally short ones (the two senses); -1 for an empty family.
/// With `weight` given (one per bond), only intact bonds (weight > 0) are candidates: a
/// broken reference would measure the skew against the crack's slip (-1 if none is intact).
Index reference_bond(std::span<const Vec2> xi, const Vec2& direction, std::span<const double> weight = {});

/// Skew of every bond of a family (paper eqs 20-23): R rotates the reference bond r from its
/// reference to its current direction; each bond's current vector rotated back,
/// xi' = R^T (xi + eta), gives
///   gamma = |(xi' - xi) . e1| / max(|xi . e2|, min_sin |xi|)   with e1 along xi_r.
/// min_sin = 0 is the paper's eq 22, where bonds (nearly) parallel to e1
/// (|xi . e2| < 1e-9 |xi|) have no skew and get 0. min_sin = sin(failure.skew_min_angle)
/// > 0 floors the offset across e1 of bonds within that angle of the reference
/// (docs/theory/failure.md, "The skew of shallow bonds"). A rigid rotation gives 0 for
/// every bond; simple shear u = g (X . e2) e1 gives g for every bond at least the floor's
/// angle from e1, and g |xi . e2| / (min_sin |xi|) < g for the shallower ones.
void bond_skews(std::span<const Vec2> xi, std::span<const Vec2> eta, Index r, double min_sin,
                std::span<double> gamma);

}  // namespace peristat
