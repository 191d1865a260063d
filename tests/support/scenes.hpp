// Small scenes for tests, written as YAML so the tests go through the real parser.
#pragma once

#include <string>

#include "scene/scene.hpp"

namespace peristat::test {

struct PlateSpec {
  int nx = 20, ny = 10;  ///< particles along x and y
  double dx = 1e-3;
  double E = 1e9, nu = 0.3, thickness = 1e-3;
  double m = 3.0;
  std::string kinematics = "finite";
  std::string quadrature = "isotropic";
  std::string surface_correction;  ///< discretization.surface_correction; empty: the default
  int steps = 1;
  std::string boundary;  ///< YAML list items under `boundary:` (indented 2)
  std::string cracks;    ///< YAML list items under `cracks:` (indented 2)
  std::string solver;    ///< YAML mapping items under `solver:` (indented 2)
};

/// A single rectangular plate [0, nx dx] x [0, ny dx].
std::string plate_yaml(const PlateSpec& spec);

/// cases/tension_plate/scene.yaml with its right grip moved by `grip_ux` (e.g. "2.0e-3": a
/// 2 % stretch of the 0.1 m plate; the case's own is 1.0e-4) in `steps` load steps.
std::string stretched_tension_plate(const std::string& grip_ux, int steps);

/// Parses YAML text (path "test.yaml" in messages).
Scene scene_from_yaml(const std::string& text);

/// A uniaxial tension plate: left edge ux = 0, right edge ux = strain * length, uy = 0 on
/// the mid-height particles of the left layers' region.
std::string tension_boundary(double strain, const PlateSpec& spec);
/// The same with grips on the body's own surface (`layers: 0`): ux = 0 on the leftmost
/// column of particles, ux = strain * length on the rightmost.
std::string surface_tension_boundary(double strain, const PlateSpec& spec);
/// The same with mirror grips (`mirror: true`, docs/theory/osb.md section 7): each end edge
/// is a frictionless platen, the body reflected across it two horizons deep.
std::string mirror_tension_boundary(double strain, const PlateSpec& s);

/// A 40 x 20 plate (dx = 1 mm, E = 1 GPa, m = 3) with an edge notch from the left edge to
/// x = 15 mm at mid-height, pulled apart by `pull` [m] at the top edge (bottom uy = 0, one
/// corner particle ux = 0). With `failure`, critical stretch from G_c = 10 J/m^2:
/// s_c = 2.1e-3 (docs/theory/failure.md). `solver` and `loading` are YAML flow maps;
/// `extra` is appended (e.g. a contact section).
std::string notch_yaml(double pull, bool failure, const std::string& solver = "{linear: umfpack}",
                       const std::string& extra = "", const std::string& kinematics = "small",
                       const std::string& loading = "{steps: 1}");

/// Case 4.1's two plates at dx = 1 mm (E = 60 GPa, nu = 0.2), the right one pressed by 0.8 mm
/// and the left one pulled up by `slide` [m] in 12 steps: a large slide along their declared
/// interface. `contact` is the contact section's body after `interfaces` (e.g. "friction: 0");
/// `extra` is appended (e.g. a solver section).
std::string large_slide_yaml(const std::string& slide, const std::string& contact,
                             const std::string& extra = "");

/// A 44 x 40 plate between mirror grips (a 0.1 % stretch): for the ranks' parts, every part
/// holds the mirror layers near it and the rings around them (6 columns into the plate), and
/// 44 x 40 leaves the middle strip of three and each of four bands across y short of the whole.
Scene mirror_grip_plate();

/// A 24 x 36 plate held on its left edge by fictitious layers and pulled on its right, cut by a
/// slanted pre-crack that crosses every split of the parts' tests.
Scene slanted_crack_plate();

}  // namespace peristat::test
