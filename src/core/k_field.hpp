// The near-tip displacement field of linear elastic fracture mechanics (Williams), plane
// stress: what a K-field boundary condition prescribes (`boundary: - {k_field: ...}`,
// docs/guide/scene.md), so that a disc or square around a crack tip carries a pure mixed-mode
// K_I, K_II field on its rim (a boundary-layer analysis).
#pragma once

#include "core/types.hpp"

namespace peristat {

struct KField {
  double K_I = 0.0, K_II = 0.0;       ///< stress intensity factors at load factor 1 [Pa sqrt(m)]
  Vec2 tip = Vec2::Zero();            ///< the crack tip
  Vec2 direction = Vec2(1.0, 0.0);    ///< unit vector ahead of the tip; the crack lies behind it
  double mu = 0.0;                    ///< shear modulus of the body's material [Pa]
  double kappa = 0.0;                 ///< Kolosov's constant, plane stress (3 - nu) / (1 + nu)

  /// The displacement at reference position X: (K / 2 mu) sqrt(r / 2 pi) times the angular
  /// functions of modes I and II, in the tip's frame (angle phi in (-pi, pi] from
  /// `direction`, so the faces are phi = +-pi), rotated back to x, y.
  Vec2 at(const Vec2& X) const;
};

}  // namespace peristat
