// Scene parser: a full scene round-trips, defaults hold, every bad input names file,
// line and key, and --set overrides reach the tree before validation.
#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>

#include "scene/scene.hpp"

namespace peristat {
namespace {

// The minimal valid scene, in three parts so tests can swap one. Line numbers (1-based)
// are given in the comments because the tests assert on them.
const std::string k_head =  // lines 1-8
    "name: minimal\n"
    "materials:\n"
    "  plate:\n"
    "    E: 1.0e9\n"
    "    nu: 0.3\n"
    "    thickness: 1.0e-3\n"
    "discretization:\n"
    "  spacing: 1.0e-3\n";
const std::string k_bodies =  // lines 9-12
    "bodies:\n"
    "  plate:\n"
    "    material: plate\n"
    "    rectangle: {min: [0, 0], max: [0.02, 0.01]}\n";
const std::string k_boundary =  // lines 13-20
    "boundary:\n"
    "  - body: plate\n"
    "    edge: left\n"
    "    ux: 0\n"
    "    uy: 0\n"
    "  - body: plate\n"
    "    edge: right\n"
    "    ux: 1.0e-5\n";
const std::string k_minimal = k_head + k_bodies + k_boundary;

/// `text` with the one occurrence of `from` replaced by `to`.
std::string replace(std::string text, const std::string& from, const std::string& to) {
  const auto at = text.find(from);
  EXPECT_NE(at, std::string::npos) << "test bug: \"" << from << "\" not in the scene";
  if (at != std::string::npos) text.replace(at, from.size(), to);
  return text;
}

/// The InputError message of parsing `text`, or "" (and a failure) if it parses.
std::string error_of(const std::string& text, const std::vector<Override>& overrides = {}) {
  try {
    parse_scene_text(text, "scene.yaml", overrides);
  } catch (const InputError& e) {
    return e.what();
  }
  ADD_FAILURE() << "expected an InputError for:\n" << text;
  return "";
}

/// Parsing fails with a message that starts at `where` ("scene.yaml:5: materials.plate.nu")
/// and mentions `what`.
void expect_error(const std::string& text, const std::string& where, const std::string& what,
                  const std::vector<Override>& overrides = {}) {
  const std::string message = error_of(text, overrides);
  EXPECT_EQ(message.rfind(where + ": ", 0), 0u) << "message: " << message << "\nexpected at: " << where;
  EXPECT_NE(message.find(what), std::string::npos) << "message: " << message << "\nexpected: " << what;
}

Scene parse(const std::string& text, const std::vector<Override>& overrides = {}) {
  return parse_scene_text(text, "scene.yaml", overrides);
}

const std::string k_full = R"(name: full_scene-1.0
materials:
  steel:
    E: 2.0e11
    nu: 0.25
    thickness: 2.0e-3
    kinematics: small
  soft:
    E: 1.0e6
    nu: -0.5
    thickness: 1.0e-2
    kinematics: finite
discretization:
  spacing: 5.0e-4
  horizon_factor: 3.5
  fictitious_layers: 2
  quadrature: partial
  origin: [0.1, -0.2]
bodies:
  plate:
    material: steel
    rectangle: {min: [0, 0], max: [0.04, 0.02]}
  wedge:
    material: soft
    polygon: [[0.05, 0], [0.08, 0], [0.05, 0.03]]
cracks:
  - {from: [0.01, 0.01], to: [0.02, 0.01]}
  - from: [-0.01, 0.0]
    to: [0.0, 0.0]
boundary:
  - body: plate
    edge: left
    layers: 4
    ux: 0
    uy: {value: 1.0e-6, grad: [0, -1.0e-4]}
  - body: wedge
    edge: 2
    uy: {grad: [2.0e-3, 0]}
  - body: plate
    surround: true
    ux: {value: -1.0e-6}
  - body: plate
    region: {min: [0.03, 0], max: [0.04, 0.02]}
    uy: 0
loading:
  steps: 10
  max_cutbacks: 3
solver:
  type: adr
  linear: bicgstab
  krylov: {rtol: 1.0e-8, max_iterations: 500, preconditioner: bond}
  newton: {rtol: 1.0e-9, atol: 1.0e-12, stol: 1.0e-7, max_iterations: 40,
           line_search: false, line_search_max: 3, tangent: initial}
  adr: {rtol: 1.0e-7, max_iterations: 5000, on_budget: accept, density_factor: 1.5, report_every: 250, breaking: iterations}
output:
  every: 2
)";

void expect_full_scene(const Scene& s) {
  EXPECT_EQ(s.name, "full_scene-1.0");
  EXPECT_EQ(s.path, "scene.yaml");
  ASSERT_EQ(s.materials.size(), 2u);
  const Material& steel = s.materials.at("steel");
  EXPECT_EQ(steel.name, "steel");
  EXPECT_EQ(steel.E, 2.0e11);
  EXPECT_EQ(steel.nu, 0.25);
  EXPECT_EQ(steel.thickness, 2.0e-3);
  EXPECT_EQ(steel.kinematics, Kinematics::small);
  EXPECT_EQ(steel.where.describe(), "scene.yaml:3: materials.steel");
  const Material& soft = s.materials.at("soft");
  EXPECT_EQ(soft.nu, -0.5);
  EXPECT_EQ(soft.kinematics, Kinematics::finite);

  const Discretization& d = s.discretization;
  EXPECT_EQ(d.spacing, 5.0e-4);
  EXPECT_EQ(d.horizon_factor, 3.5);
  EXPECT_EQ(d.fictitious_layers, 2);
  EXPECT_EQ(d.quadrature, Quadrature::partial);
  EXPECT_EQ(d.origin, Vec2(0.1, -0.2));
  EXPECT_EQ(d.where.describe(), "scene.yaml:13: discretization");

  ASSERT_EQ(s.bodies.size(), 2u);
  const Body& plate = s.bodies[0];
  EXPECT_EQ(plate.name, "plate");
  EXPECT_EQ(plate.material, "steel");
  EXPECT_TRUE(plate.is_rectangle);
  const std::vector<Vec2> rect{{0, 0}, {0.04, 0}, {0.04, 0.02}, {0, 0.02}};
  EXPECT_EQ(plate.shape.vertices, rect);
  EXPECT_EQ(plate.where.describe(), "scene.yaml:20: bodies.plate");
  const Body& wedge = s.bodies[1];
  EXPECT_EQ(wedge.name, "wedge");
  EXPECT_FALSE(wedge.is_rectangle);
  const std::vector<Vec2> tri{{0.05, 0}, {0.08, 0}, {0.05, 0.03}};
  EXPECT_EQ(wedge.shape.vertices, tri);

  ASSERT_EQ(s.cracks.size(), 2u);
  EXPECT_EQ(s.cracks[0].a, Vec2(0.01, 0.01));
  EXPECT_EQ(s.cracks[0].b, Vec2(0.02, 0.01));
  EXPECT_EQ(s.cracks[0].where.describe(), "scene.yaml:27: cracks.0");
  EXPECT_EQ(s.cracks[1].where.describe(), "scene.yaml:28: cracks.1");  // touches the plate's corner

  ASSERT_EQ(s.boundary.size(), 4u);
  const BoundaryCondition& left = s.boundary[0];
  EXPECT_EQ(left.body, "plate");
  EXPECT_EQ(left.selector, BoundaryCondition::Selector::edge);
  EXPECT_EQ(left.edge, 3);
  EXPECT_EQ(left.edge_name, "left");
  EXPECT_EQ(left.layers, 4);
  ASSERT_TRUE(left.ux && left.uy);
  EXPECT_EQ(left.ux->value, 0.0);
  EXPECT_EQ(left.ux->grad, Vec2::Zero());
  EXPECT_EQ(left.uy->value, 1.0e-6);
  EXPECT_EQ(left.uy->grad, Vec2(0, -1.0e-4));
  EXPECT_EQ(left.where.describe(), "scene.yaml:31: boundary.0");
  const BoundaryCondition& hyp = s.boundary[1];
  EXPECT_EQ(hyp.body, "wedge");
  EXPECT_EQ(hyp.edge, 2);
  EXPECT_EQ(hyp.edge_name, "2");
  EXPECT_EQ(hyp.layers, 2);  // discretization.fictitious_layers
  EXPECT_FALSE(hyp.ux);
  ASSERT_TRUE(hyp.uy);
  EXPECT_EQ(hyp.uy->value, 0.0);
  EXPECT_EQ(hyp.uy->grad, Vec2(2.0e-3, 0));
  const BoundaryCondition& all = s.boundary[2];
  EXPECT_EQ(all.selector, BoundaryCondition::Selector::surround);
  ASSERT_TRUE(all.ux);
  EXPECT_EQ(all.ux->value, -1.0e-6);
  EXPECT_FALSE(all.uy);
  const BoundaryCondition& box = s.boundary[3];
  EXPECT_EQ(box.selector, BoundaryCondition::Selector::region);
  EXPECT_EQ(box.lo, Vec2(0.03, 0));
  EXPECT_EQ(box.hi, Vec2(0.04, 0.02));

  EXPECT_EQ(s.loading.steps, 10);
  EXPECT_EQ(s.loading.max_cutbacks, 3);
  EXPECT_EQ(s.solver.type, SolverKind::adr);
  EXPECT_EQ(s.solver.linear.type, LinearSolverKind::bicgstab);
  EXPECT_EQ(s.solver.linear.rtol, 1.0e-8);
  EXPECT_EQ(s.solver.linear.max_iterations, 500);
  EXPECT_EQ(s.solver.linear.preconditioner, PreconditionerKind::bond);
  EXPECT_EQ(s.solver.newton.rtol, 1.0e-9);
  EXPECT_EQ(s.solver.newton.atol, 1.0e-12);
  EXPECT_EQ(s.solver.newton.stol, 1.0e-7);
  EXPECT_EQ(s.solver.newton.max_iterations, 40);
  EXPECT_FALSE(s.solver.newton.line_search);
  EXPECT_EQ(s.solver.newton.line_search_max, 3);
  EXPECT_EQ(s.solver.newton.tangent, TangentKind::initial);
  EXPECT_EQ(s.solver.adr.rtol, 1.0e-7);
  EXPECT_EQ(s.solver.adr.max_iterations, 5000);
  EXPECT_TRUE(s.solver.adr.accept_on_budget);
  EXPECT_EQ(s.solver.adr.density_factor, 1.5);
  EXPECT_EQ(s.solver.adr.report_every, 250);
  EXPECT_TRUE(s.solver.adr.break_during);
  EXPECT_FALSE(AdrOptions{}.break_during);  // between equilibria unless asked
  EXPECT_EQ(s.output.every, 2);
}

// ---- valid scenes ----------------------------------------------------------------------

TEST(SceneParse, FullSceneHasEveryField) {
  expect_full_scene(parse(k_full));
}

TEST(SceneParse, EmittedTextParsesToTheSameScene) {
  const Scene first = parse(k_full);
  expect_full_scene(parse(first.text));
}

TEST(SceneParse, MinimalSceneGetsTheDocumentedDefaults) {
  const Scene s = parse(k_minimal);
  const Material& m = s.materials.at("plate");
  EXPECT_EQ(m.E, 1.0e9);
  EXPECT_EQ(m.kinematics, Kinematics::finite);
  EXPECT_EQ(s.discretization.spacing, 1.0e-3);
  EXPECT_EQ(s.discretization.horizon_factor, 3.0);
  EXPECT_EQ(s.discretization.fictitious_layers, 3);
  EXPECT_EQ(s.discretization.quadrature, Quadrature::isotropic);
  EXPECT_EQ(s.discretization.origin, Vec2::Zero());
  EXPECT_TRUE(s.cracks.empty());
  ASSERT_EQ(s.boundary.size(), 2u);
  EXPECT_EQ(s.boundary[0].edge, 3);
  EXPECT_EQ(s.boundary[0].layers, 3);
  EXPECT_EQ(s.boundary[1].edge, 1);
  EXPECT_EQ(s.boundary[1].edge_name, "right");
  ASSERT_TRUE(s.boundary[1].ux);
  EXPECT_EQ(s.boundary[1].ux->value, 1.0e-5);
  EXPECT_FALSE(s.boundary[1].uy);
  EXPECT_EQ(s.loading.steps, 1);
  EXPECT_EQ(s.loading.max_cutbacks, 6);
  const SolverOptions defaults;
  EXPECT_EQ(s.solver.type, SolverKind::newton);
  EXPECT_EQ(s.solver.linear.type, LinearSolverKind::automatic);
  EXPECT_EQ(s.solver.linear.rtol, defaults.linear.rtol);
  EXPECT_EQ(s.solver.linear.preconditioner, PreconditionerKind::automatic);
  EXPECT_EQ(s.solver.newton.rtol, defaults.newton.rtol);
  EXPECT_EQ(s.solver.newton.max_iterations, defaults.newton.max_iterations);
  EXPECT_TRUE(s.solver.newton.line_search);
  EXPECT_EQ(s.solver.newton.tangent, TangentKind::consistent);
  EXPECT_EQ(s.solver.adr.max_iterations, defaults.adr.max_iterations);
  EXPECT_EQ(s.output.every, 1);
}

TEST(SceneParse, RectangleEdgesAcceptNamesAndIndices) {
  const char* names[] = {"bottom", "right", "top", "left"};
  for (int k = 0; k < 4; ++k) {
    const std::string edge = "    edge: " + std::string(names[k]) + "\n";
    EXPECT_EQ(parse(replace(k_minimal, "    edge: left\n", edge)).boundary[0].edge, k);
    const std::string index = "    edge: " + std::to_string(k) + "\n";
    EXPECT_EQ(parse(replace(k_minimal, "    edge: left\n", index)).boundary[0].edge, k);
  }
}

/// One edge condition on body "plate" (polygon bodies take edge indices only).
std::string polygon_condition(const std::string& edge) {
  return "boundary:\n  - body: plate\n    edge: " + edge + "\n    ux: 0\n";
}

TEST(SceneParse, ClockwisePolygonIsReversedAndEdgesKeepTheirSegments) {
  // Clockwise unit square as written: edge k runs from written vertex k to k+1.
  const std::vector<Vec2> written{{0, 0}, {0, 1}, {1, 1}, {1, 0}};
  const std::string bodies =
      "bodies:\n  plate:\n    material: plate\n    polygon: [[0, 0], [0, 1], [1, 1], [1, 0]]\n";
  for (int k = 0; k < 4; ++k) {
    const Scene s = parse(k_head + bodies + polygon_condition(std::to_string(k)));
    const std::vector<Vec2>& v = s.bodies[0].shape.vertices;
    ASSERT_EQ(v.size(), 4u);
    EXPECT_GT((v[1] - v[0]).x() * (v[2] - v[0]).y() - (v[1] - v[0]).y() * (v[2] - v[0]).x(), 0.0)
        << "stored polygon is not counter-clockwise";
    const int j = s.boundary[0].edge;
    const Vec2 a = v[j], b = v[(j + 1) % 4];
    const Vec2 p = written[k], q = written[(k + 1) % 4];
    EXPECT_TRUE((a == p && b == q) || (a == q && b == p)) << "user edge " << k << " became stored edge " << j;
    EXPECT_EQ(s.boundary[0].edge_name, std::to_string(k));
  }
}

TEST(SceneParse, CounterClockwisePolygonIsKeptAsWritten) {
  const std::string bodies =
      "bodies:\n  plate:\n    material: plate\n    polygon: [[0, 0], [1, 0], [1, 1], [0, 1]]\n";
  const Scene s = parse(k_head + bodies + polygon_condition("3"));
  const std::vector<Vec2> ccw{{0, 0}, {1, 0}, {1, 1}, {0, 1}};
  EXPECT_EQ(s.bodies[0].shape.vertices, ccw);
  EXPECT_EQ(s.boundary[0].edge, 3);
}

TEST(SceneParse, ReadsAFileAndReportsAMissingOne) {
  const auto dir = std::filesystem::temp_directory_path() / "peristat_test_scene";
  std::filesystem::create_directories(dir);
  const std::string path = (dir / "scene.yaml").string();
  std::ofstream(path) << k_minimal;
  EXPECT_EQ(parse_scene(path).path, path);
  const std::string missing = (dir / "missing.yaml").string();
  try {
    parse_scene(missing);
    ADD_FAILURE() << "expected an InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(missing), std::string::npos) << e.what();
  }
  std::filesystem::remove_all(dir);
}

// ---- bad input: every message starts with file:line: key ---------------------------------

TEST(SceneErrors, UnknownKeyAtTopLevelListsTheAllowedKeys) {
  expect_error(k_minimal + "fracture:\n  enabled: true\n", "scene.yaml:21: fracture",
               "unknown key \"fracture\": expected one of name, materials, discretization, bodies, "
               "cracks, boundary, contact, failure, loading, solver, output");
}

TEST(SceneFailure, ParsesTheSectionAndChecksIt) {
  const Scene s = parse_scene_text(
      k_minimal + "failure: {criterion: skew, G_c: 5.0e4, direction: [1, 1], fraction: 0.5}\n", "scene.yaml");
  EXPECT_TRUE(s.failure.enabled);
  EXPECT_EQ(s.failure.criterion, FailureCriterion::skew);
  EXPECT_EQ(s.failure.G_c, 5.0e4);
  EXPECT_EQ(s.failure.direction, Vec2(1.0, 1.0));
  EXPECT_EQ(s.failure.fraction, 0.5);
  EXPECT_FALSE(parse_scene_text(k_minimal, "scene.yaml").failure.enabled);  // absent: no failure checks
  expect_error(k_minimal + "failure: {criterion: skew, G_c: 1.0}\n", "scene.yaml:21: failure",
               "criterion skew needs direction");
  expect_error(k_minimal + "failure: {criterion: stretch}\n", "scene.yaml:21: failure.G_c",
               "missing required key");
  expect_error(k_minimal + "failure: {criterion: stretch, G_c: 1.0, fraction: 0}\n",
               "scene.yaml:21: failure.fraction", "0 < fraction <= 1");
  // The skew's floor angle: 45 degrees unless given, 0 is the paper's eq 22, [0, 90).
  EXPECT_EQ(s.failure.skew_min_angle, 45.0);
  EXPECT_EQ(parse_scene_text(k_minimal + "failure: {criterion: skew, G_c: 1.0, direction: [1, 0], skew_min_angle: 0}\n",
                             "scene.yaml")
                .failure.skew_min_angle,
            0.0);
  expect_error(k_minimal + "failure: {criterion: skew, G_c: 1.0, direction: [1, 0], skew_min_angle: 90}\n",
               "scene.yaml:21: failure.skew_min_angle", "0 <= skew_min_angle < 90");
  expect_error(k_minimal + "failure: {criterion: stretch, G_c: 1.0, skew_min_angle: 30}\n",
               "scene.yaml:21: failure.skew_min_angle", "applies to criterion skew only");
  // The skew's calibration factor: 1 (eq 19) unless given, > 0, skew only.
  EXPECT_EQ(s.failure.skew_scale, 1.0);
  EXPECT_EQ(parse_scene_text(k_minimal + "failure: {criterion: skew, G_c: 1.0, direction: [1, 0], skew_scale: 1.37}\n",
                             "scene.yaml")
                .failure.skew_scale,
            1.37);
  expect_error(k_minimal + "failure: {criterion: skew, G_c: 1.0, direction: [1, 0], skew_scale: 0}\n",
               "scene.yaml:21: failure.skew_scale", "expected skew_scale > 0");
  expect_error(k_minimal + "failure: {criterion: stretch, G_c: 1.0, skew_scale: 1.37}\n",
               "scene.yaml:21: failure.skew_scale", "applies to criterion skew only");
}

TEST(SceneErrors, UnknownKeyInNestedMaps) {
  expect_error(replace(k_minimal, "    E: 1.0e9", "    Young: 1.0e9"), "scene.yaml:4: materials.plate.Young",
               "expected one of E, nu, thickness, kinematics");
  expect_error(replace(k_minimal, "  spacing: 1.0e-3", "  spacing: 1.0e-3\n  horizon: 3"),
               "scene.yaml:9: discretization.horizon", "unknown key");
  expect_error(replace(k_minimal, "    ux: 1.0e-5", "    uz: 1.0e-5"), "scene.yaml:20: boundary.1.uz",
               "unknown key");
  expect_error(k_minimal + "solver:\n  newton: {rtol: 1e-8, line_serch: false}\n",
               "scene.yaml:22: solver.newton.line_serch", "line_search");
  expect_error(k_minimal + "cracks:\n  - {from: [0, 0], to: [1, 1], width: 1}\n",
               "scene.yaml:22: cracks.0.width", "expected one of from, to");
}

TEST(SceneErrors, WrongTypes) {
  expect_error(replace(k_minimal, "E: 1.0e9", "E: stiff"), "scene.yaml:4: materials.plate.E",
               "expected a number, found \"stiff\"");
  expect_error(replace(k_minimal, "nu: 0.3", "nu: \"0.3\""), "scene.yaml:5: materials.plate.nu",
               "expected a number");
  expect_error(replace(k_minimal, "spacing: 1.0e-3", "spacing: [1.0e-3]"),
               "scene.yaml:8: discretization.spacing", "expected a number, found a list");
  expect_error(k_head + k_bodies + "boundary: {body: plate}\n", "scene.yaml:13: boundary",
               "expected a list, found a map");
  expect_error(k_head + k_bodies + "boundary:\n  - plate\n", "scene.yaml:14: boundary.0", "expected a map");
  expect_error(k_minimal + "loading: {steps: 2.5}\n", "scene.yaml:21: loading.steps",
               "expected an integer, found \"2.5\"");
  expect_error(k_minimal + "solver:\n  newton: {line_search: maybe}\n",
               "scene.yaml:22: solver.newton.line_search", "expected true or false");
  expect_error(k_minimal + "solver: {linear: superlu}\n", "scene.yaml:21: solver.linear",
               "expected one of auto, cholmod, umfpack, klu, ldlt, cg, bicgstab, belos");
  expect_error(replace(k_minimal, "  spacing: 1.0e-3", "  spacing: 1.0e-3\n  origin: [0, 0, 0]"),
               "scene.yaml:9: discretization.origin", "expected a point [x, y]");
  expect_error(replace(k_minimal, "    uy: 0\n", "    uy: [0, 1]\n"), "scene.yaml:17: boundary.0.uy",
               "expected a number or {value: v, grad: [gx, gy]}");
  expect_error(replace(k_minimal, "    E: 1.0e9", "    E: .nan"), "scene.yaml:4: materials.plate.E",
               "expected a finite number");
}

// A plain scalar keeps a trailing form feed that yaml-cpp's conversion skipped: "1.0e9\f" was
// read as 1e9, then written quoted into the scene as run, which did not parse again (found by
// tests/fuzz, crashes/scene/crash-6e0f2868...).
TEST(SceneErrors, NumbersHoldNoControlCharacters) {
  expect_error(replace(k_minimal, "E: 1.0e9", "E: 1.0e9\f"), "scene.yaml:4: materials.plate.E",
               "expected a number, found \"1.0e9\f\"");
  expect_error(k_minimal + "loading: {steps: 2\v}\n", "scene.yaml:21: loading.steps", "expected an integer");
  const Scene scene = parse(k_minimal);
  EXPECT_EQ(parse(scene.text).text, scene.text);  // the scene as run parses again, to itself
}

TEST(SceneErrors, MissingRequiredKeysPointAtTheParent) {
  expect_error(replace(k_minimal, "    E: 1.0e9\n", ""), "scene.yaml:3: materials.plate.E",
               "missing required key \"E\"");
  expect_error(replace(k_minimal, "  spacing: 1.0e-3\n", "  horizon_factor: 2\n"),
               "scene.yaml:7: discretization.spacing", "missing required key \"spacing\"");
  expect_error(replace(k_minimal, "    material: plate\n", ""), "scene.yaml:10: bodies.plate.material",
               "missing required key");
  expect_error(replace(k_minimal, "  - body: plate\n    edge: right", "  - edge: right"),
               "scene.yaml:18: boundary.1.body", "missing required key \"body\"");
  expect_error(replace(k_minimal, "name: minimal\n", "# no name\n"), "scene.yaml:2: name",
               "missing required key \"name\"");
  expect_error(k_head + k_boundary, "scene.yaml:1: bodies", "missing required key \"bodies\"");
  expect_error(replace(k_minimal, "    rectangle: {min: [0, 0], max: [0.02, 0.01]}\n", ""),
               "scene.yaml:10: bodies.plate", "expected exactly one of rectangle");
  expect_error(replace(k_minimal, "{min: [0, 0], max", "{max"), "scene.yaml:12: bodies.plate.rectangle.min",
               "missing required key \"min\"");
}

TEST(SceneErrors, MaterialRanges) {
  expect_error(replace(k_minimal, "E: 1.0e9", "E: 0"), "scene.yaml:4: materials.plate.E",
               "value 0 is out of range: expected E > 0");
  expect_error(replace(k_minimal, "E: 1.0e9", "E: -1.0e9"), "scene.yaml:4: materials.plate.E",
               "out of range");
  expect_error(replace(k_minimal, "nu: 0.3", "nu: 0.7"), "scene.yaml:5: materials.plate.nu",
               "value 0.7 is out of range: expected -1 < nu < 0.5");
  expect_error(replace(k_minimal, "nu: 0.3", "nu: 0.5"), "scene.yaml:5: materials.plate.nu", "out of range");
  expect_error(replace(k_minimal, "nu: 0.3", "nu: -1"), "scene.yaml:5: materials.plate.nu", "out of range");
  expect_error(replace(k_minimal, "thickness: 1.0e-3", "thickness: 0.0"),
               "scene.yaml:6: materials.plate.thickness", "expected thickness > 0");
  expect_error(replace(k_minimal, "    thickness: 1.0e-3", "    thickness: 1.0e-3\n    kinematics: large"),
               "scene.yaml:7: materials.plate.kinematics", "expected one of finite, small");
}

TEST(SceneErrors, DiscretizationRanges) {
  expect_error(replace(k_minimal, "spacing: 1.0e-3", "spacing: 0"), "scene.yaml:8: discretization.spacing",
               "expected spacing > 0");
  expect_error(replace(k_minimal, "spacing: 1.0e-3", "spacing: -1.0e-3"),
               "scene.yaml:8: discretization.spacing", "out of range");
  expect_error(replace(k_minimal, "  spacing: 1.0e-3", "  spacing: 1.0e-3\n  horizon_factor: 0.5"),
               "scene.yaml:9: discretization.horizon_factor", "expected horizon_factor >= 1");
  expect_error(replace(k_minimal, "  spacing: 1.0e-3", "  spacing: 1.0e-3\n  fictitious_layers: -1"),
               "scene.yaml:9: discretization.fictitious_layers", "expected fictitious_layers >= 0");
  expect_error(replace(k_minimal, "  spacing: 1.0e-3", "  spacing: 1.0e-3\n  surface_correction: volume"),
               "scene.yaml:9: discretization.surface_correction", "none");
}

TEST(SceneErrors, SolverAndLoadingRanges) {
  expect_error(k_minimal + "loading: {steps: 0}\n", "scene.yaml:21: loading.steps", "expected steps >= 1");
  expect_error(k_minimal + "loading: {max_cutbacks: -1}\n", "scene.yaml:21: loading.max_cutbacks",
               "expected max_cutbacks >= 0");
  expect_error(k_minimal + "solver:\n  newton:\n    rtol: 0\n", "scene.yaml:23: solver.newton.rtol",
               "expected rtol > 0");
  expect_error(k_minimal + "solver:\n  newton:\n    atol: -1e-3\n", "scene.yaml:23: solver.newton.atol",
               "expected atol >= 0");
  expect_error(k_minimal + "solver:\n  adr: {max_iterations: 0}\n",
               "scene.yaml:22: solver.adr.max_iterations", "expected max_iterations >= 1");
  expect_error(k_minimal + "solver:\n  adr: {density_factor: 0.5}\n",
               "scene.yaml:22: solver.adr.density_factor", "density_factor >= 1");
  expect_error(k_minimal + "solver:\n  adr: {on_budget: keep}\n", "scene.yaml:22: solver.adr.on_budget",
               "fail, accept");
  expect_error(k_minimal + "solver:\n  adr: {breaking: always}\n", "scene.yaml:22: solver.adr.breaking",
               "equilibrium, iterations");
  expect_error(k_minimal + "output: {every: 0}\n", "scene.yaml:21: output.every", "expected every >= 1");
  expect_error(k_minimal + "solver:\n  krylov: {contact_zone: -1}\n",
               "scene.yaml:22: solver.krylov.contact_zone", "expected contact_zone >= 0");
  expect_error(k_minimal + "solver:\n  krylov: {contact_zone: 1.5}\n",
               "scene.yaml:22: solver.krylov.contact_zone", "integer");
  expect_error(k_minimal + "solver:\n  krylov: {contact_zone_cap: 0}\n",
               "scene.yaml:22: solver.krylov.contact_zone_cap", "expected contact_zone_cap > 0");
  expect_error(k_minimal + "solver:\n  krylov: {contact_zone_cap: 1.5}\n",
               "scene.yaml:22: solver.krylov.contact_zone_cap", "expected 0 < contact_zone_cap <= 1");
  const Scene zone = parse(k_minimal + "solver:\n  krylov: {contact_zone: 0, contact_zone_cap: 1}\n");
  EXPECT_EQ(zone.solver.bond_preconditioner.contact_zone_layers, 0);
  EXPECT_EQ(zone.solver.bond_preconditioner.contact_zone_cap, 1.0);
}

TEST(SceneErrors, EmptySections) {
  expect_error(k_head + "bodies: {}\n", "scene.yaml:9: bodies", "expected at least one body");
  expect_error(k_head + "bodies:\n", "scene.yaml:9: bodies", "expected at least one body");
  const std::string no_materials =
      replace(k_minimal, "materials:\n  plate:\n    E: 1.0e9\n    nu: 0.3\n    thickness: 1.0e-3\n",
              "materials: {}\n");
  expect_error(no_materials, "scene.yaml:2: materials", "expected at least one material");
  expect_error("", "scene.yaml:1", "the scene is empty");
  expect_error("- a\n- b\n", "scene.yaml:1", "expected a map");
}

TEST(SceneErrors, NamesAndReferences) {
  expect_error(replace(k_minimal, "name: minimal", "name: my run"), "scene.yaml:1: name",
               "invalid name \"my run\"");
  expect_error(replace(k_minimal, "material: plate", "material: steel"),
               "scene.yaml:11: bodies.plate.material", "unknown material \"steel\": expected one of plate");
  expect_error(replace(k_minimal, "  - body: plate\n    edge: right", "  - body: plat\n    edge: right"),
               "scene.yaml:18: boundary.1.body", "unknown body \"plat\": expected one of plate");
  expect_error(replace(k_minimal, "edge: left", "edge: lft"), "scene.yaml:15: boundary.0.edge",
               "unknown edge \"lft\" of body plate: expected bottom, right, top, left or 0..3");
  expect_error(replace(k_minimal, "edge: left", "edge: 4"), "scene.yaml:15: boundary.0.edge", "unknown edge");
  const std::string triangle =
      "bodies:\n  plate:\n    material: plate\n    polygon: [[0, 0], [1, 0], [0, 1]]\n";
  expect_error(k_head + triangle + k_boundary, "scene.yaml:15: boundary.0.edge", "expected an integer 0..2");
  expect_error(replace(k_minimal, "  plate:\n    material", "  my plate:\n    material"),
               "scene.yaml:10: bodies.my plate", "invalid body name");
}

TEST(SceneErrors, DegenerateShapes) {
  expect_error(replace(k_minimal, "max: [0.02, 0.01]", "max: [0, 0.01]"),
               "scene.yaml:12: bodies.plate.rectangle", "degenerate rectangle");
  const std::string head_bodies = k_head + "bodies:\n  plate:\n    material: plate\n";
  expect_error(head_bodies + "    polygon: [[0, 0], [1, 1], [2, 2]]\n", "scene.yaml:12: bodies.plate.polygon",
               "degenerate polygon");
  expect_error(head_bodies + "    polygon: [[0, 0], [1, 1]]\n", "scene.yaml:12: bodies.plate.polygon",
               "at least 3 vertices");
  expect_error(head_bodies + "    polygon: [[0, 0], [1, 1], [1, 0], [0, 1]]\n",
               "scene.yaml:12: bodies.plate.polygon", "edges 0 and 2 intersect");
  expect_error(head_bodies + "    polygon: [[0, 0], [1, 0], [1, 0], [0, 1]]\n",
               "scene.yaml:12: bodies.plate.polygon", "vertices 1 and 2 coincide");
  expect_error(
      head_bodies + "    rectangle: {min: [0, 0], max: [1, 1]}\n    polygon: [[0, 0], [1, 0], [0, 1]]\n",
      "scene.yaml:13: bodies.plate.polygon", "found both");
}

TEST(SceneErrors, BoundaryConditionShape) {
  expect_error(replace(k_minimal, "    ux: 1.0e-5\n", ""), "scene.yaml:18: boundary.1",
               "expected at least one of ux, uy");
  expect_error(replace(k_minimal, "    edge: right\n", ""), "scene.yaml:18: boundary.1",
               "expected exactly one of edge, surround, region, block, found 0");
  expect_error(replace(k_minimal, "    edge: right\n", "    edge: right\n    surround: true\n"),
               "scene.yaml:18: boundary.1", "found 2");
  expect_error(
      replace(k_minimal, "    edge: right\n", "    region: {min: [0, 0], max: [1, 1]}\n    layers: 2\n"),
      "scene.yaml:20: boundary.1.layers", "not allowed with region");
  expect_error(replace(k_minimal, "    edge: right\n", "    surround: false\n"),
               "scene.yaml:19: boundary.1.surround", "expected true");
  expect_error(replace(k_minimal, "    edge: right\n", "    region: {min: [1, 0], max: [0, 1]}\n"),
               "scene.yaml:19: boundary.1.region", "degenerate region");
  expect_error(
      replace(k_minimal, "    edge: right\n", "    block: {min: [0, 0], max: [1, 1]}\n    layers: 2\n"),
      "scene.yaml:20: boundary.1.layers", "not allowed with block");
  expect_error(replace(k_minimal, "    edge: right\n", "    block: {min: [0, 1], max: [1, 0]}\n"),
               "scene.yaml:19: boundary.1.block", "degenerate block");
  expect_error(replace(k_minimal, "    edge: left\n", "    edge: left\n    layers: -1\n"),
               "scene.yaml:16: boundary.0.layers", "expected layers >= 0");
}

TEST(SceneErrors, CrackOutsideEveryBody) {
  expect_error(k_minimal +
                   "cracks:\n  - {from: [0.001, 0.005], to: [0.01, 0.005]}\n"
                   "  - {from: [0.05, 0.05], to: [0.06, 0.06]}\n",
               "scene.yaml:23: cracks.1", "crack lies outside every body");
  expect_error(k_minimal + "cracks:\n  - {from: [0.01, 0.005], to: [0.01, 0.005]}\n",
               "scene.yaml:22: cracks.0", "zero length");
  // A crack that crosses the body without an end inside it is fine.
  EXPECT_EQ(parse(k_minimal + "cracks:\n  - {from: [-1, 0.005], to: [1, 0.005]}\n").cracks.size(), 1u);
}

TEST(SceneErrors, DuplicateKeys) {
  expect_error(replace(k_minimal, "    nu: 0.3\n", "    nu: 0.3\n    E: 2.0e9\n"),
               "scene.yaml:6: materials.plate.E", "duplicate key \"E\": already given at line 4");
  expect_error(k_minimal + "bodies:\n  other: {material: plate, rectangle: {min: [1, 1], max: [2, 2]}}\n",
               "scene.yaml:21: bodies", "duplicate key");
}

TEST(SceneErrors, YamlSyntaxErrorsGiveTheLine) {
  expect_error(replace(k_minimal, "    nu: 0.3", "     nu: 0.3"), "scene.yaml:5", "YAML syntax error");
  expect_error(replace(k_minimal, "max: [0.02, 0.01]}", "max: [0.02, 0.01]"), "scene.yaml:13",
               "YAML syntax error");
  expect_error(k_minimal + "---\nname: second\n", "scene.yaml:22", "found 2 YAML documents");
}

// yaml-cpp 0.7 returns empty documents forever at a ',' outside [ ] or { } where a document
// starts: YAML::LoadAll hung (found by tests/fuzz, crashes/scene/timeout-7b176a32...).
TEST(SceneErrors, StrayCommaIsASyntaxErrorNotAHang) {
  expect_error(",name: x\n", "scene.yaml:1", "YAML syntax error: unexpected text at column 1");
  expect_error("[a],\n", "scene.yaml:1", "YAML syntax error: unexpected text at column 4");
  expect_error(k_minimal + "---\n,\n", "scene.yaml:22", "YAML syntax error: unexpected text at column 1");
}

// ---- contact ---------------------------------------------------------------------------

// Three bodies: left and right share the segment x = 0.01, top sits on both.
const std::string k_contact_bodies =  // lines 9-18
    "bodies:\n"
    "  left:\n"
    "    material: plate\n"
    "    rectangle: {min: [0, 0], max: [0.01, 0.01]}\n"
    "  right:\n"
    "    material: plate\n"
    "    rectangle: {min: [0.01, 0], max: [0.02, 0.01]}\n"
    "  top:\n"
    "    material: plate\n"
    "    rectangle: {min: [0, 0.01], max: [0.02, 0.02]}\n";
const std::string k_contact_rest =  // lines 19-28
    "cracks:\n"
    "  - {from: [0.002, 0.005], to: [0.008, 0.005]}\n"
    "boundary:\n"
    "  - body: left\n"
    "    edge: left\n"
    "    ux: 0\n"
    "    uy: 0\n"
    "  - body: right\n"
    "    edge: right\n"
    "    ux: 1.0e-5\n";
const std::string k_contact_section =  // lines 29-40
    "contact:\n"
    "  enabled: true\n"
    "  friction: 0.8\n"
    "  radius_factor: 0.8\n"
    "  normal: pair\n"
    "  stiffness: 31.0e9\n"
    "  tangential_factor: 2.0\n"
    "  gate: 0.25\n"
    "  cracks: false\n"
    "  interfaces:\n"
    "    - bodies: [left, right]\n"
    "    - bodies: [top, left]\n";
const std::string k_no_contact = k_head + k_contact_bodies + k_contact_rest;
const std::string k_contact = k_no_contact + k_contact_section;

void expect_default_contact_values(const ContactOptions& c) {
  EXPECT_EQ(c.friction, 0.0);
  EXPECT_EQ(c.radius_factor, 1.0);
  EXPECT_EQ(c.normal, NormalLaw::paper);
  EXPECT_EQ(c.stiffness, 0.0);
  EXPECT_EQ(c.tangential_factor, 1.0);
  EXPECT_EQ(c.gate, 0.1);
  EXPECT_TRUE(c.cracks);
  EXPECT_TRUE(c.interfaces.empty());
}

void expect_full_contact(const ContactOptions& c) {
  EXPECT_TRUE(c.enabled);
  EXPECT_EQ(c.friction, 0.8);
  EXPECT_EQ(c.radius_factor, 0.8);
  EXPECT_EQ(c.normal, NormalLaw::pair);
  EXPECT_EQ(c.stiffness, 31.0e9);
  EXPECT_EQ(c.tangential_factor, 2.0);
  EXPECT_EQ(c.gate, 0.25);
  EXPECT_FALSE(c.cracks);
  ASSERT_EQ(c.interfaces.size(), 2u);
  EXPECT_EQ(c.interfaces[0].body_a, "left");
  EXPECT_EQ(c.interfaces[0].body_b, "right");
  EXPECT_EQ(c.interfaces[1].body_a, "top");
  EXPECT_EQ(c.interfaces[1].body_b, "left");
}

TEST(SceneContact, AbsentSectionMeansNoContact) {
  for (const std::string& text : {k_minimal, k_no_contact}) {
    const ContactOptions c = parse(text).contact;
    EXPECT_FALSE(c.enabled);
    expect_default_contact_values(c);
  }
}

TEST(SceneContact, FullSectionHasEveryField) {
  const Scene s = parse(k_contact);
  expect_full_contact(s.contact);
  EXPECT_EQ(s.contact.where.describe(), "scene.yaml:29: contact");
  EXPECT_EQ(s.contact.interfaces[0].where.describe(), "scene.yaml:39: contact.interfaces.0");
  EXPECT_EQ(s.contact.interfaces[1].where.describe(), "scene.yaml:40: contact.interfaces.1");
  EXPECT_EQ(s.cracks.size(), 1u);
  EXPECT_EQ(s.bodies.size(), 3u);
}

TEST(SceneContact, EmittedTextParsesToTheSameContact) {
  expect_full_contact(parse(parse(k_contact).text).contact);
  EXPECT_FALSE(parse(parse(k_contact, {parse_override("contact.enabled=false")}).text).contact.enabled);
}

TEST(SceneContact, PresentSectionIsEnabledWithDefaults) {
  for (const char* section : {"contact:\n", "contact: {}\n", "contact:\n  enabled: true\n"}) {
    const ContactOptions c = parse(k_minimal + section).contact;
    EXPECT_TRUE(c.enabled) << section;
    expect_default_contact_values(c);
    EXPECT_EQ(c.where.describe(), "scene.yaml:21: contact");
  }
  EXPECT_FALSE(parse(replace(k_contact, "  enabled: true\n", "  enabled: false\n")).contact.enabled);
  EXPECT_TRUE(parse(replace(k_contact, "  enabled: true\n", "")).contact.enabled);
  // Without `stiffness` the modulus is left to the materials (eq 17).
  EXPECT_EQ(parse(replace(k_contact, "  stiffness: 31.0e9\n", "")).contact.stiffness, 0.0);
  EXPECT_EQ(parse(replace(k_contact, "normal: pair", "normal: paper")).contact.normal, NormalLaw::paper);
  EXPECT_EQ(parse(replace(k_contact, "gate: 0.25", "gate: 0")).contact.gate, 0.0);
  EXPECT_EQ(parse(replace(k_contact, "friction: 0.8", "friction: 0")).contact.friction, 0.0);
}

TEST(SceneContact, EnabledWithNothingToDoIsValid) {
  // No cracks, no interfaces: contact is on but has no candidates.
  const ContactOptions a = parse(k_minimal + "contact:\n  enabled: true\n").contact;
  EXPECT_TRUE(a.enabled);
  EXPECT_TRUE(a.interfaces.empty());
  // Cracks present but excluded, no interfaces.
  const std::string no_interfaces =
      replace(k_contact, "    - bodies: [left, right]\n    - bodies: [top, left]\n", "");
  const ContactOptions b = parse(no_interfaces).contact;
  EXPECT_TRUE(b.enabled);
  EXPECT_FALSE(b.cracks);
  EXPECT_TRUE(b.interfaces.empty());
  // Cracks are candidates but there are none.
  EXPECT_TRUE(parse(k_minimal + "contact: {cracks: true, interfaces: []}\n").contact.enabled);
}

TEST(SceneContact, Ranges) {
  expect_error(replace(k_contact, "friction: 0.8", "friction: -0.1"), "scene.yaml:31: contact.friction",
               "value -0.1 is out of range: expected friction >= 0");
  expect_error(replace(k_contact, "radius_factor: 0.8", "radius_factor: 0"),
               "scene.yaml:32: contact.radius_factor", "value 0 is out of range: expected radius_factor > 0");
  expect_error(replace(k_contact, "radius_factor: 0.8", "radius_factor: -1"),
               "scene.yaml:32: contact.radius_factor", "expected radius_factor > 0");
  expect_error(replace(k_contact, "stiffness: 31.0e9", "stiffness: 0"), "scene.yaml:34: contact.stiffness",
               "expected stiffness > 0");
  expect_error(replace(k_contact, "tangential_factor: 2.0", "tangential_factor: 0"),
               "scene.yaml:35: contact.tangential_factor", "expected tangential_factor > 0");
  expect_error(replace(k_contact, "gate: 0.25", "gate: 1"), "scene.yaml:36: contact.gate",
               "value 1 is out of range: expected 0 <= gate < 1");
  expect_error(replace(k_contact, "gate: 0.25", "gate: -0.1"), "scene.yaml:36: contact.gate",
               "expected 0 <= gate < 1");
}

TEST(SceneContact, ChoicesAndTypes) {
  expect_error(replace(k_contact, "normal: pair", "normal: hertz"), "scene.yaml:33: contact.normal",
               "value \"hertz\" is not allowed: expected one of paper, pair");
  expect_error(replace(k_contact, "enabled: true", "enabled: maybe"), "scene.yaml:30: contact.enabled",
               "expected true or false, found \"maybe\"");
  expect_error(replace(k_contact, "cracks: false", "cracks: 1.5"), "scene.yaml:37: contact.cracks",
               "expected true or false");
  expect_error(replace(k_contact, "friction: 0.8", "friction: high"), "scene.yaml:31: contact.friction",
               "expected a number, found \"high\"");
  expect_error(k_minimal + "contact: true\n", "scene.yaml:21: contact", "expected a map");
  expect_error(k_minimal + "contact:\n  interfaces: {bodies: [a, b]}\n", "scene.yaml:22: contact.interfaces",
               "expected a list, found a map");
}

// contact.stick (docs/theory/contact.md section 8): exact stick is the default of exact
// enforcement; `stick: penalty` keeps the tangential penalty there; exact stick without exact
// enforcement has no multiplier loop to run in and is refused at its line.
TEST(SceneContact, StickKey) {
  EXPECT_TRUE(parse(k_minimal + "contact: {enforcement: exact, friction: 0.3}\n").contact.exact_stick);
  EXPECT_FALSE(
      parse(k_minimal + "contact: {enforcement: exact, friction: 0.3, stick: penalty}\n").contact.exact_stick);
  EXPECT_TRUE(
      parse(k_minimal + "contact: {enforcement: exact, friction: 0.3, stick: exact}\n").contact.exact_stick);
  expect_error(k_minimal + "contact:\n  enforcement: penalty\n  friction: 0.3\n  stick: exact\n",
               "scene.yaml:24: contact.stick", "stick: exact needs enforcement: exact");
  // Exact is the default enforcement, so stick: exact alone is fine.
  EXPECT_TRUE(parse(k_minimal + "contact: {friction: 0.3, stick: exact}\n").contact.exact_stick);
  expect_error(k_minimal + "contact:\n  enforcement: exact\n  stick: glue\n", "scene.yaml:23: contact.stick",
               "value \"glue\" is not allowed: expected one of exact, penalty");
}

// Exact enforcement is the default (the continuum's non-penetration); the pair law, which has
// no normal to enforce, defaults to the penalty; the paper's law is asked for by name.
TEST(SceneContact, EnforcementDefaultsToExact) {
  EXPECT_EQ(parse(k_minimal + "contact: {friction: 0.3}\n").contact.enforcement, ContactEnforcement::exact);
  EXPECT_EQ(parse(k_minimal + "contact: {normal: pair}\n").contact.enforcement, ContactEnforcement::penalty);
  EXPECT_EQ(parse(k_minimal + "contact: {enforcement: penalty}\n").contact.enforcement,
            ContactEnforcement::penalty);
  expect_error(k_minimal + "contact:\n  normal: pair\n  enforcement: exact\n",
               "scene.yaml:23: contact.enforcement", "enforcement: exact needs normal: paper");
}

// The closure reference of exact contact (docs/theory/contact.md, "The closure's reference"):
// the material's strain on the faces of broken bonds by default, on every face or nowhere on
// request, and refused where nothing measures a closure (penalty).
TEST(SceneContact, ClosureReferenceDefaultsToTheBrokenBonds) {
  EXPECT_EQ(parse(k_minimal + "contact: {friction: 0.3}\n").contact.closure_reference,
            ClosureReference::broken_bonds);
  EXPECT_EQ(parse(k_minimal + "contact: {closure_reference: spacing}\n").contact.closure_reference,
            ClosureReference::spacing);
  EXPECT_EQ(parse(k_minimal + "contact: {closure_reference: material}\n").contact.closure_reference,
            ClosureReference::material);
  expect_error(k_minimal + "contact:\n  enforcement: penalty\n  closure_reference: material\n",
               "scene.yaml:23: contact.closure_reference", "closure_reference needs enforcement: exact");
  expect_error(k_minimal + "contact:\n  closure_reference: strain\n",
               "scene.yaml:22: contact.closure_reference", "spacing");
}

TEST(SceneContact, UnknownKeys) {
  expect_error(replace(k_contact, "  gate: 0.25\n", "  gate: 0.25\n  mu: 0.3\n"), "scene.yaml:37: contact.mu",
               "unknown key \"mu\": expected one of enabled, friction, radius_factor, normal, stiffness, "
               "tangential_factor, gate, cracks, interfaces");
  expect_error(replace(k_contact, "    - bodies: [top, left]\n", "    - {bodies: [top, left], gap: 0}\n"),
               "scene.yaml:40: contact.interfaces.1.gap", "unknown key \"gap\": expected one of bodies");
  expect_error(replace(k_contact, "    - bodies: [top, left]\n", "    - {pair: [top, left]}\n"),
               "scene.yaml:40: contact.interfaces.1.pair", "unknown key");
  expect_error(replace(k_contact, "    - bodies: [top, left]\n", "    - {}\n"),
               "scene.yaml:40: contact.interfaces.1.bodies", "missing required key \"bodies\"");
  expect_error(replace(k_contact, "  friction: 0.8\n", "  friction: 0.8\n  friction: 0.1\n"),
               "scene.yaml:32: contact.friction", "duplicate key \"friction\": already given at line 31");
}

TEST(SceneContact, InterfaceBodies) {
  expect_error(replace(k_contact, "[top, left]", "[top, middle]"),
               "scene.yaml:40: contact.interfaces.1.bodies.1",
               "unknown body \"middle\": expected one of left, right, top");
  expect_error(replace(k_contact, "[left, right]", "[lft, right]"),
               "scene.yaml:39: contact.interfaces.0.bodies.0", "unknown body \"lft\"");
  expect_error(replace(k_contact, "[top, left]", "[left, left]"),
               "scene.yaml:40: contact.interfaces.1.bodies.1",
               "body \"left\" is named twice: expected two different bodies");
  expect_error(replace(k_contact, "[top, left]", "[top, left, right]"),
               "scene.yaml:40: contact.interfaces.1.bodies",
               "expected exactly two body names [a, b], found a list of 3");
  expect_error(replace(k_contact, "[top, left]", "[top]"), "scene.yaml:40: contact.interfaces.1.bodies",
               "found a list of 1");
  expect_error(replace(k_contact, "[top, left]", "top"), "scene.yaml:40: contact.interfaces.1.bodies",
               "expected a list, found \"top\"");
  expect_error(replace(k_contact, "[top, left]", ""), "scene.yaml:40: contact.interfaces.1.bodies",
               "expected exactly two body names [a, b], found nothing (null)");
}

TEST(SceneContact, Overrides) {
  const Scene s =
      parse(k_contact, {parse_override("contact.friction=0.01"), parse_override("contact.enabled=false"),
                        parse_override("contact.radius_factor=0.8"), parse_override("contact.normal=paper"),
                        parse_override("contact.gate=0"), parse_override("contact.cracks=true"),
                        parse_override("contact.interfaces.1.bodies=[top, right]")});
  EXPECT_EQ(s.contact.friction, 0.01);
  EXPECT_FALSE(s.contact.enabled);
  EXPECT_EQ(s.contact.radius_factor, 0.8);
  EXPECT_EQ(s.contact.normal, NormalLaw::paper);
  EXPECT_EQ(s.contact.gate, 0.0);
  EXPECT_TRUE(s.contact.cracks);
  ASSERT_EQ(s.contact.interfaces.size(), 2u);
  EXPECT_EQ(s.contact.interfaces[1].body_b, "right");
  EXPECT_EQ(s.contact.interfaces[1].where.describe(), "scene.yaml:40: contact.interfaces.1");
  EXPECT_EQ(parse(k_contact, {parse_override("contact.normal=pair")}).contact.normal, NormalLaw::pair);
  EXPECT_EQ(parse(k_contact, {parse_override("contact.radius_factor=1.5")}).contact.radius_factor, 1.5);
}

TEST(SceneContact, OverrideOnAnAbsentSectionCreatesIt) {
  // As for every section, --set creates a missing map, and a present section is enabled.
  const Scene on = parse(k_minimal, {parse_override("contact.enabled=true")});
  EXPECT_TRUE(on.contact.enabled);
  expect_default_contact_values(on.contact);
  EXPECT_EQ(on.contact.where.describe(), "--set: contact");
  const Scene friction = parse(k_minimal, {parse_override("contact.friction=0.01")});
  EXPECT_TRUE(friction.contact.enabled);
  EXPECT_EQ(friction.contact.friction, 0.01);
  EXPECT_NE(friction.text.find("contact:"), std::string::npos) << friction.text;
  EXPECT_FALSE(parse(k_minimal, {parse_override("contact.enabled=false")}).contact.enabled);
  EXPECT_FALSE(
      parse(k_minimal, {parse_override("contact.friction=0.01"), parse_override("contact.enabled=false")})
          .contact.enabled);
}

TEST(SceneContact, OverrideErrorsSayDashDashSet) {
  expect_error(k_contact, "--set: contact.friction", "expected friction >= 0",
               {parse_override("contact.friction=-1")});
  expect_error(k_contact, "--set: contact.radius_factor", "expected radius_factor > 0",
               {parse_override("contact.radius_factor=0")});
  expect_error(k_contact, "--set: contact.normal", "expected one of paper, pair",
               {parse_override("contact.normal=hertz")});
  expect_error(k_contact, "--set: contact.gate", "expected 0 <= gate < 1",
               {parse_override("contact.gate=1")});
  expect_error(k_contact, "--set: contact.interfaces.0.bodies.1", "named twice",
               {parse_override("contact.interfaces.0.bodies=[right, right]")});
  expect_error(k_minimal, "--set: contact.mu", "unknown key \"mu\"", {parse_override("contact.mu=0.3")});
  expect_error(k_minimal, "--set: contact.interfaces.0.bodies.1",
               "unknown body \"right\": expected one of plate",
               {parse_override("contact.interfaces=[{bodies: [plate, right]}]")});
  expect_error(
      k_minimal, "--set: contact.interfaces.2", "index 2 is out of range",
      {parse_override("contact.interfaces=[]"), parse_override("contact.interfaces.2.bodies=[a, b]")});
}

// ---- --set overrides -------------------------------------------------------------------

TEST(SceneOverrides, ParseOverrideSplitsAtTheFirstEquals) {
  const Override o = parse_override("solver.linear=umfpack");
  EXPECT_EQ(o.key, "solver.linear");
  EXPECT_EQ(o.value, "umfpack");
  EXPECT_EQ(parse_override(" loading.steps = 4 ").key, "loading.steps");
  EXPECT_EQ(parse_override("name=a=b").value, "a=b");
  EXPECT_EQ(parse_override("name=").value, "");
  for (const char* bad : {"solver.linear", "=umfpack", "solver..linear=cg", ".a=1", "a.=1"}) {
    try {
      parse_override(bad);
      ADD_FAILURE() << "expected an InputError for " << bad;
    } catch (const InputError& e) {
      EXPECT_EQ(std::string(e.what()).rfind("--set", 0), 0u) << e.what();
    }
  }
}

TEST(SceneOverrides, NumberOverrideReplacesTheValueAndTheText) {
  const Scene s = parse(k_minimal, {parse_override("discretization.spacing=2.5e-4")});
  EXPECT_EQ(s.discretization.spacing, 2.5e-4);
  EXPECT_NE(s.text.find("spacing: 2.5e-4"), std::string::npos) << s.text;
  EXPECT_EQ(s.text.find("spacing: 1.0e-3"), std::string::npos) << s.text;
  EXPECT_EQ(parse(s.text).discretization.spacing, 2.5e-4);
}

TEST(SceneOverrides, ListIndexAndFlowValues) {
  const Scene s = parse(k_minimal, {parse_override("boundary.1.ux=3e-5"),
                                    parse_override("boundary.0.uy={value: 1, grad: [2, 3]}"),
                                    parse_override("discretization.origin=[1, 2]")});
  EXPECT_EQ(s.boundary[1].ux->value, 3e-5);
  EXPECT_EQ(s.boundary[0].uy->value, 1.0);
  EXPECT_EQ(s.boundary[0].uy->grad, Vec2(2, 3));
  EXPECT_EQ(s.discretization.origin, Vec2(1, 2));
}

TEST(SceneOverrides, MissingMapsAreCreated) {
  const Scene s = parse(k_minimal, {parse_override("solver.newton.line_search=false"),
                                    parse_override("solver.newton.rtol=1e-6")});
  EXPECT_FALSE(s.solver.newton.line_search);
  EXPECT_EQ(s.solver.newton.rtol, 1e-6);
  EXPECT_NE(s.text.find("rtol: 1e-6"), std::string::npos) << s.text;
}

TEST(SceneOverrides, EveryContractKeyWorks) {
  const Scene s =
      parse(k_minimal,
            {parse_override("discretization.spacing=5e-4"), parse_override("discretization.horizon_factor=4"),
             parse_override("loading.steps=7"), parse_override("solver.type=adr"),
             parse_override("solver.linear=umfpack"), parse_override("solver.newton.rtol=1e-7"),
             parse_override("solver.adr.rtol=1e-5"), parse_override("solver.adr.max_iterations=123"),
             parse_override("materials.plate.kinematics=small"), parse_override("materials.plate.E=2e9"),
             parse_override("materials.plate.nu=0.2")});
  EXPECT_EQ(s.discretization.spacing, 5e-4);
  EXPECT_EQ(s.discretization.horizon_factor, 4.0);
  EXPECT_EQ(s.loading.steps, 7);
  EXPECT_EQ(s.solver.type, SolverKind::adr);
  EXPECT_EQ(s.solver.linear.type, LinearSolverKind::umfpack);
  EXPECT_EQ(s.solver.newton.rtol, 1e-7);
  EXPECT_EQ(s.solver.adr.rtol, 1e-5);
  EXPECT_EQ(s.solver.adr.max_iterations, 123);
  const Material& m = s.materials.at("plate");
  EXPECT_EQ(m.kinematics, Kinematics::small);
  EXPECT_EQ(m.E, 2e9);
  EXPECT_EQ(m.nu, 0.2);
}

TEST(SceneOverrides, ErrorsInOverriddenKeysSayDashDashSet) {
  expect_error(k_minimal, "--set: solver.lnear", "unknown key \"lnear\"",
               {parse_override("solver.lnear=umfpack")});
  expect_error(k_minimal, "--set: materials.plate.nu", "value 0.7 is out of range",
               {parse_override("materials.plate.nu=0.7")});
  expect_error(k_minimal, "--set: fracture", "unknown key \"fracture\"",
               {parse_override("fracture.critical_stretch=0.1")});
  expect_error(k_minimal, "--set: materials.steel.nu", "missing required key",
               {parse_override("materials.steel.E=1e9")});
  expect_error(k_minimal, "--set: boundary.5", "index 5 is out of range: boundary is a list of 2 entries",
               {parse_override("boundary.5.ux=0")});
  expect_error(k_minimal, "--set: boundary.x", "not a list index", {parse_override("boundary.x=0")});
  expect_error(k_minimal, "--set: name.x", "not a map", {parse_override("name.x=1")});
  expect_error(k_minimal, "--set: loading.steps", "cannot read the value",
               {parse_override("loading.steps=[1")});
  // An error elsewhere still points into the file.
  expect_error(replace(k_minimal, "E: 1.0e9", "E: 0"), "scene.yaml:4: materials.plate.E", "out of range",
               {parse_override("loading.steps=3")});
}

TEST(SceneOverrides, OverrideCanRepairTheFile) {
  const Scene s = parse(replace(k_minimal, "nu: 0.3", "nu: 0.7"), {parse_override("materials.plate.nu=0.1")});
  EXPECT_EQ(s.materials.at("plate").nu, 0.1);
}

}  // namespace
}  // namespace peristat

namespace peristat {
namespace {

// solver.belos.* (issue 16): every key through --set, the defaults, and a bad value named
// with its key.
TEST(Scene, BelosKeys) {
  const Scene d = parse(k_minimal, {parse_override("solver.linear=belos")});
  EXPECT_EQ(d.solver.linear.type, LinearSolverKind::belos);
  EXPECT_EQ(d.solver.linear.belos.method, BelosMethod::automatic);
  EXPECT_EQ(d.solver.linear.belos.preconditioner, BelosPreconditioner::muelu);
  EXPECT_EQ(d.solver.linear.belos.partition, BelosPartition::rcb);
  EXPECT_EQ(d.solver.linear.belos.tangent, BelosTangent::matrix_free);
  // The retired keys are refused by name, with what replaced them (every run under mpirun on
  // the ranks' parts), not as unknown keys.
  for (const char* key : {"solver.belos.bonds=whole", "solver.belos.model=whole", "solver.belos.model=part"}) {
    const std::string retired = error_of(k_minimal, {parse_override(key)});
    EXPECT_NE(retired.find(std::string(key).substr(0, std::string(key).find('='))), std::string::npos) << retired;
    EXPECT_NE(retired.find("retired"), std::string::npos) << retired;
    EXPECT_NE(retired.find("its own part of the model"), std::string::npos) << retired;
  }
  const Scene s =
      parse(k_minimal,
            {parse_override("solver.linear=belos"), parse_override("solver.belos.method=gmres"),
             parse_override("solver.belos.preconditioner=ifpack2_ilut"),
             parse_override("solver.belos.partition=strips"),
             parse_override("solver.belos.tangent=assembled"), parse_override("solver.belos.rtol=1e-8"),
             parse_override("solver.belos.max_iterations=50"), parse_override("solver.belos.restart=30")});
  EXPECT_EQ(s.solver.linear.belos.method, BelosMethod::gmres);
  EXPECT_EQ(s.solver.linear.belos.preconditioner, BelosPreconditioner::ifpack2_ilut);
  EXPECT_EQ(s.solver.linear.belos.rtol, 1e-8);
  EXPECT_EQ(s.solver.linear.belos.max_iterations, 50);
  EXPECT_EQ(s.solver.linear.belos.restart, 30);
  EXPECT_EQ(s.solver.linear.belos.partition, BelosPartition::strips);
  EXPECT_EQ(s.solver.linear.belos.tangent, BelosTangent::assembled);
  const std::string tangent = error_of(k_minimal, {parse_override("solver.belos.tangent=free")});
  EXPECT_NE(tangent.find("solver.belos.tangent"), std::string::npos) << tangent;
  EXPECT_NE(tangent.find("matrix_free"), std::string::npos) << "the choices are listed: " << tangent;
  const std::string partition = error_of(k_minimal, {parse_override("solver.belos.partition=metis")});
  EXPECT_NE(partition.find("solver.belos.partition"), std::string::npos) << partition;
  EXPECT_NE(partition.find("rcb"), std::string::npos) << "the choices are listed: " << partition;
  const std::string message = error_of(k_minimal, {parse_override("solver.belos.preconditioner=amesos")});
  EXPECT_NE(message.find("solver.belos.preconditioner"), std::string::npos) << message;
  EXPECT_NE(message.find("ifpack2_ilut"), std::string::npos) << "the choices are listed: " << message;
}

// Issue 17's solver levers: solver.linear auto (the default), solver.newton.forcing and
// loading.predictor, their defaults and their refusals.
TEST(Scene, AutoSolverForcingAndPredictorKeys) {
  const Scene d = parse(k_minimal);
  EXPECT_EQ(d.solver.linear.type, LinearSolverKind::automatic);
  EXPECT_TRUE(d.solver.newton.adaptive_forcing);
  EXPECT_TRUE(d.loading.extrapolate);
  const Scene s = parse(k_minimal, {parse_override("solver.linear=auto"), parse_override("solver.newton.forcing=fixed"),
                                    parse_override("loading.predictor=previous")});
  EXPECT_EQ(s.solver.linear.type, LinearSolverKind::automatic);
  EXPECT_FALSE(s.solver.newton.adaptive_forcing);
  EXPECT_FALSE(s.loading.extrapolate);
  std::string message = error_of(k_minimal, {parse_override("solver.newton.forcing=eisenstat")});
  EXPECT_NE(message.find("solver.newton.forcing"), std::string::npos) << message;
  EXPECT_NE(message.find("adaptive, fixed"), std::string::npos) << "the choices are listed: " << message;
  message = error_of(k_minimal, {parse_override("loading.predictor=quadratic")});
  EXPECT_NE(message.find("loading.predictor"), std::string::npos) << message;
  EXPECT_NE(message.find("extrapolate, previous"), std::string::npos) << "the choices are listed: " << message;
}

}  // namespace
}  // namespace peristat

namespace peristat {
namespace {

// solver.belos.muelu_parameters names a file the parser can read; a missing one is refused
// with the key's location, before any solve.
TEST(Scene, MueLuParametersMustBeReadable) {
  const std::string message = error_of(k_minimal, {parse_override("solver.belos.muelu_parameters=/nonexistent/muelu.xml")});
  EXPECT_NE(message.find("solver.belos.muelu_parameters"), std::string::npos) << message;
  EXPECT_NE(message.find("cannot read"), std::string::npos) << message;
}

// k_field: both components from the Williams field of the body's material (nu = 0.3 here:
// mu = E / 2.6, kappa = 2.7 / 1.3), the direction normalised; refused beside ux or uy, with
// mirror, without a tip or with a zero direction, each at its key.
TEST(SceneParse, KFieldPrescribesBothComponentsFromTheMaterial) {
  const std::string kf = replace(k_minimal, "    ux: 0\n    uy: 0\n",
                                 "    k_field: {K_I: 2.0e6, K_II: -1.0e6, tip: [0.01, 0.005], direction: [0, 2]}\n");
  const Scene s = parse(kf);
  const BoundaryCondition& bc = s.boundary[0];
  ASSERT_TRUE(bc.ux && bc.uy && bc.ux->k && bc.uy->k);
  EXPECT_EQ(bc.ux->k_component, 0);
  EXPECT_EQ(bc.uy->k_component, 1);
  EXPECT_EQ(bc.ux->k->K_I, 2.0e6);
  EXPECT_EQ(bc.ux->k->K_II, -1.0e6);
  EXPECT_EQ(bc.ux->k->tip, Vec2(0.01, 0.005));
  EXPECT_EQ(bc.ux->k->direction, Vec2(0, 1));
  EXPECT_DOUBLE_EQ(bc.ux->k->mu, 1.0e9 / 2.6);
  EXPECT_DOUBLE_EQ(bc.ux->k->kappa, 2.7 / 1.3);
  const Vec2 X(0.0, 0.0);
  EXPECT_EQ(bc.ux->at(X), bc.ux->k->at(X).x());
  EXPECT_EQ(bc.uy->at(X), bc.uy->k->at(X).y());
  expect_error(replace(kf, "    k_field:", "    ux: 0\n    k_field:"), "scene.yaml:16: boundary.0.ux",
               "ux is not allowed with k_field");
  expect_error(replace(kf, "tip: [0.01, 0.005], ", ""), "scene.yaml:16: boundary.0.k_field.tip",
               "missing required key \"tip\"");
  expect_error(replace(kf, "direction: [0, 2]", "direction: [0, 0]"),
               "scene.yaml:16: boundary.0.k_field.direction", "expected a non-zero direction");
  expect_error(replace(kf, "K_I: 2.0e6, K_II: -1.0e6, ", ""), "scene.yaml:16: boundary.0.k_field",
               "expected at least one of K_I, K_II");
  expect_error(replace(kf, "    edge: left\n", "    edge: left\n    mirror: true\n"),
               "scene.yaml:17: boundary.0.k_field", "k_field is not allowed with mirror");
}

}  // namespace
}  // namespace peristat
