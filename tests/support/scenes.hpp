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
  int steps = 1;
  std::string boundary;  ///< YAML list items under `boundary:` (indented 2)
  std::string cracks;    ///< YAML list items under `cracks:` (indented 2)
  std::string solver;    ///< YAML mapping items under `solver:` (indented 2)
};

/// A single rectangular plate [0, nx dx] x [0, ny dx].
std::string plate_yaml(const PlateSpec& spec);

/// Parses YAML text (path "test.yaml" in messages).
Scene scene_from_yaml(const std::string& text);

/// A uniaxial tension plate: left edge ux = 0, right edge ux = strain * length, uy = 0 on
/// the mid-height particles of the left layers' region.
std::string tension_boundary(double strain, const PlateSpec& spec);

}  // namespace peristat::test
