#include "support/scenes.hpp"

#include <sstream>
#include <stdexcept>

#include "support/cli.hpp"

namespace peristat::test {

std::string stretched_tension_plate(const std::string& grip_ux, int steps) {
  std::string text = read_file(std::string(PERISTAT_SOURCE_DIR) + "/cases/tension_plate/scene.yaml");
  auto replace = [&](const std::string& from, const std::string& to) {
    const auto at = text.find(from);
    if (at == std::string::npos)
      throw std::runtime_error("cases/tension_plate/scene.yaml has no '" + from + "'");
    text.replace(at, from.size(), to);
  };
  replace("ux: 1.0e-4}", "ux: " + grip_ux + "}");
  replace("steps: 2\n", "steps: " + std::to_string(steps) + "\n");
  return text;
}

std::string plate_yaml(const PlateSpec& s) {
  std::ostringstream y;
  y.precision(17);
  y << "name: test_plate\n"
    << "materials:\n  mat:\n    E: " << s.E << "\n    nu: " << s.nu << "\n    thickness: " << s.thickness
    << "\n    kinematics: " << s.kinematics << "\n"
    << "discretization:\n  spacing: " << s.dx << "\n  horizon_factor: " << s.m
    << "\n  quadrature: " << s.quadrature << "\n";
  if (!s.surface_correction.empty()) y << "  surface_correction: " << s.surface_correction << "\n";
  y
    << "bodies:\n  plate:\n    material: mat\n    rectangle: {min: [0, 0], max: [" << s.nx * s.dx << ", "
    << s.ny * s.dx << "]}\n"
    << "loading:\n  steps: " << s.steps << "\n";
  if (!s.boundary.empty()) y << "boundary:\n" << s.boundary;
  if (!s.cracks.empty()) y << "cracks:\n" << s.cracks;
  if (!s.solver.empty()) y << "solver:\n" << s.solver;
  return y.str();
}

Scene scene_from_yaml(const std::string& text) {
  return parse_scene_text(text, "test.yaml");
}

std::string tension_boundary(double strain, const PlateSpec& s) {
  std::ostringstream y;
  y.precision(17);
  const double L = s.nx * s.dx, H = s.ny * s.dx;
  y << "  - {body: plate, edge: left, ux: 0}\n"
    << "  - {body: plate, edge: right, ux: " << strain * L
    << "}\n"
    // uy = 0 on the two real particles nearest mid-height at the left end: no rigid motion
    << "  - {body: plate, region: {min: [0, " << 0.5 * H - s.dx << "], max: [" << s.dx << ", "
    << 0.5 * H + s.dx << "]}, uy: 0}\n";
  return y.str();
}

namespace {
/// Tension grips given by `grip` ("layers: 0", "mirror: true") and the mid-height uy support.
std::string gripped_tension_boundary(double strain, const PlateSpec& s, const std::string& grip) {
  std::ostringstream y;
  y.precision(17);
  const double L = s.nx * s.dx, H = s.ny * s.dx;
  y << "  - {body: plate, edge: left, " << grip << ", ux: 0}\n"
    << "  - {body: plate, edge: right, " << grip << ", ux: " << strain * L << "}\n"
    << "  - {body: plate, region: {min: [0, " << 0.5 * H - s.dx << "], max: [" << s.dx << ", "
    << 0.5 * H + s.dx << "]}, uy: 0}\n";
  return y.str();
}
}  // namespace

std::string surface_tension_boundary(double strain, const PlateSpec& s) {
  return gripped_tension_boundary(strain, s, "layers: 0");
}

std::string mirror_tension_boundary(double strain, const PlateSpec& s) {
  return gripped_tension_boundary(strain, s, "mirror: true");
}

std::string notch_yaml(double pull, bool failure, const std::string& solver, const std::string& extra,
                       const std::string& kinematics, const std::string& loading) {
  std::string y = R"(name: notch
materials:
  m: {E: 1.0e9, nu: 0.3, thickness: 1.0e-3, kinematics: )" + kinematics + R"(}
discretization: {spacing: 1.0e-3, horizon_factor: 3}
bodies:
  plate: {material: m, rectangle: {min: [0, 0], max: [0.04, 0.02]}}
cracks:
  - {from: [-0.001, 0.01], to: [0.015, 0.01]}
boundary:
  - {body: plate, edge: bottom, uy: 0}
  - {body: plate, edge: top, uy: )" + std::to_string(pull) + R"(}
  - {body: plate, region: {min: [0.039, 0], max: [0.04, 0.001]}, ux: 0}
loading: )" + loading + R"(
solver: )" + solver + "\n";
  if (failure) y += "failure: {criterion: stretch, G_c: 10.0}\n";
  return y + extra;
}

std::string large_slide_yaml(const std::string& slide, const std::string& contact, const std::string& extra) {
  return "name: large_slide\n"
         "materials:\n  plate: {E: 60.0e9, nu: 0.2, thickness: 2.0e-3, kinematics: small}\n"
         "discretization: {spacing: 1.0e-3, horizon_factor: 3, fictitious_layers: 3}\n"
         "bodies:\n"
         "  left: {material: plate, rectangle: {min: [0.0, 0.0], max: [0.032, 0.06]}}\n"
         "  right: {material: plate, rectangle: {min: [0.032, 0.0], max: [0.064, 0.06]}}\n"
         "boundary:\n"
         "  - {body: right, edge: right, ux: -8.0e-4}\n"
         "  - {body: left, edge: top, uy: " +
         slide +
         "}\n"
         "  - {body: left, edge: left, ux: 0.0}\n"
         "  - {body: right, edge: bottom, uy: 0.0}\n"
         "contact:\n  interfaces:\n    - {bodies: [left, right]}\n  " +
         contact + "\nloading: {steps: 12}\n" + extra;
}

Scene mirror_grip_plate() {
  PlateSpec spec;
  spec.nx = 44;
  spec.ny = 40;
  spec.boundary = mirror_tension_boundary(1e-3, spec);
  return scene_from_yaml(plate_yaml(spec));
}

Scene slanted_crack_plate() {
  PlateSpec spec;
  spec.nx = 24;
  spec.ny = 36;
  spec.boundary = "  - {body: plate, edge: left, ux: 0, uy: 0}\n  - {body: plate, edge: right, ux: 1.0e-5}\n";
  spec.cracks = "  - {from: [0.0051, 0.0063], to: [0.0187, 0.0297]}\n";
  return scene_from_yaml(plate_yaml(spec));
}

}  // namespace peristat::test
