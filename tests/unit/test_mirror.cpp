// Mirror grips (`mirror: true` on an edge condition, docs/theory/osb.md section 7): the
// fictitious layers reflect the body across the edge line, two stencil reaches deep; the
// normal component of a ghost is 2 U - u_n(image), the tangential one u_t(image). Checked
// here: the layers and their images, the expansion of the unknowns, and the refusals.
#include <cmath>
#include <cstdio>
#include <random>
#include <string>

#include <gtest/gtest.h>

#include "discretisation/model.hpp"
#include "core/error.hpp"
#include "support/scenes.hpp"
#include "support/solve.hpp"

namespace peristat {
namespace {

test::PlateSpec mirror_plate(const std::string& boundary) {
  test::PlateSpec spec;
  spec.nx = 16;
  spec.ny = 12;
  spec.boundary = boundary;
  return spec;
}

const std::string k_mirrors =
    "  - {body: plate, edge: left, mirror: true, ux: 0}\n"
    "  - {body: plate, edge: top, mirror: true, uy: {value: 2.0e-6, grad: [1.0e-4, 0]}}\n"
    "  - {body: plate, region: {min: [0, 0], max: [0.001, 0.001]}, uy: 0}\n";

TEST(Mirror, GhostsReflectTheBodyTwoReachesDeep) {
  const Model model = discretise(test::scene_from_yaml(test::plate_yaml(mirror_plate(k_mirrors))));
  const Particles& p = model.particles;
  const Constraints& c = model.constraints;
  const int layers = mirror_layers(3.0);
  EXPECT_EQ(layers, 8);  // the stencil reaches ceil(3 + 0.5) = 4 cells; twice that
  // Left: 8 columns of 12; top: 8 rows of 16 (the corner square is neither edge's).
  ASSERT_EQ(static_cast<Index>(c.images.size()), 8 * 12 + 8 * 16);
  ASSERT_EQ(static_cast<Index>(c.image_start.size()), p.size() + 1);
  const double dx = 1e-3, H = 12 * dx;
  for (const MirrorImage& im : c.images) {
    EXPECT_TRUE(p.fictitious[im.ghost]);
    EXPECT_FALSE(p.fictitious[im.source]);
    const Vec2 g = p.position[im.ghost], s = p.position[im.source];
    if (g.x() < 0.0) {  // left: reflected across x = 0, u_x odd, u_y even
      EXPECT_NEAR(g.x(), -s.x(), 1e-15);
      EXPECT_EQ(g.y(), s.y());
      EXPECT_EQ(im.sign[0], -1.0);
      EXPECT_EQ(im.sign[1], 1.0);
      EXPECT_EQ(c.value[2 * im.ghost], 0.0);
    } else {  // top: reflected across y = H, u_y = 2 U(x) - u_y(image)
      EXPECT_NEAR(g.y(), 2.0 * H - s.y(), 1e-15);
      EXPECT_EQ(g.x(), s.x());
      EXPECT_EQ(im.sign[0], 1.0);
      EXPECT_EQ(im.sign[1], -1.0);
      EXPECT_NEAR(c.value[2 * im.ghost + 1], 2.0 * (2.0e-6 + 1.0e-4 * g.x()), 1e-18);
    }
    EXPECT_TRUE(c.prescribed[2 * im.ghost] && c.prescribed[2 * im.ghost + 1]);
    // The CSR by source finds the image.
    bool found = false;
    for (Index k = c.image_start[im.source]; k < c.image_start[im.source + 1]; ++k)
      found = found || c.images[k].ghost == im.ghost;
    EXPECT_TRUE(found);
  }
}

// expand() writes each ghost from its image at any state: u_n(ghost) + u_n(image) = 2 lambda U
// at the foot, u_t(ghost) = u_t(image). scatter() (rates: no affine part) reflects likewise.
TEST(Mirror, ExpansionReflectsAnyState) {
  const Model model = discretise(test::scene_from_yaml(test::plate_yaml(mirror_plate(k_mirrors))));
  const Constraints& c = model.constraints;
  std::mt19937 gen(3);
  std::uniform_real_distribution<double> d(-1e-5, 1e-5);
  VectorXd x(c.n_free), u, v;
  for (Index i = 0; i < x.size(); ++i) x[i] = d(gen);
  const double lambda = 0.7;
  c.expand(x, lambda, u);
  c.scatter(x, v);
  for (const MirrorImage& im : c.images) {
    for (int k = 0; k < 2; ++k) {
      const double rigid = lambda * c.value[2 * im.ghost + k];
      EXPECT_NEAR(u[2 * im.ghost + k], rigid + im.sign[k] * u[2 * im.source + k], 1e-20);
      EXPECT_EQ(v[2 * im.ghost + k], im.sign[k] * v[2 * im.source + k]);
    }
  }
}

std::string error_of(const std::string& boundary, const std::string& extra = "", int nx = 16,
                     const std::string& origin = "") {
  test::PlateSpec spec = mirror_plate(boundary);
  spec.nx = nx;
  std::string yaml = test::plate_yaml(spec);
  if (!origin.empty()) {
    const auto at = yaml.find("  horizon_factor:");
    yaml.insert(at, "  origin: " + origin + "\n");
  }
  try {
    discretise(test::scene_from_yaml(yaml + extra));
  } catch (const InputError& e) {
    return e.what();
  }
  ADD_FAILURE() << "expected an InputError for:\n" << boundary << extra;
  return "";
}

void expect_refused(const std::string& boundary, const std::string& what, const std::string& extra = "",
                    int nx = 16, const std::string& origin = "") {
  const std::string message = error_of(boundary, extra, nx, origin);
  EXPECT_NE(message.find("boundary.0"), std::string::npos) << message;
  EXPECT_NE(message.find(what), std::string::npos) << message << "\nexpected: " << what;
}

TEST(Mirror, RefusesWhatItCannotReflect) {
  const std::string support = "  - {body: plate, region: {min: [0, 0], max: [0.016, 0.001]}, uy: 0}\n";
  // The tangential component is the image's own.
  expect_refused("  - {body: plate, edge: left, mirror: true, ux: 0, uy: 0}\n" + support, "prescribes only the normal");
  expect_refused("  - {body: plate, edge: left, mirror: true, uy: 0}\n" + support, "prescribes only the normal");
  // Not with layers, not with a region.
  expect_refused("  - {body: plate, edge: left, mirror: true, layers: 3, ux: 0}\n" + support, "layers is not allowed");
  expect_refused("  - {body: plate, region: {min: [0, 0], max: [0.001, 0.012]}, mirror: true, ux: 0}\n" + support,
                 "needs an edge");
  // A pre-crack within the mirrored depth (8 dx) of the edge.
  expect_refused("  - {body: plate, edge: left, mirror: true, ux: 0}\n" + support, "pre-crack",
                 "cracks:\n  - {from: [0.006, 0.004], to: [0.006, 0.008]}\n");
  // A body thinner than two reaches across the edge: no image for the deepest ghosts.
  expect_refused("  - {body: plate, edge: left, mirror: true, ux: 0}\n" + support, "thinner than two horizons", "",
                 6);
  // An edge line off the lattice's cell boundaries (lattice shifted by half a spacing).
  expect_refused("  - {body: plate, edge: left, mirror: true, ux: 0}\n" + support, "cell boundary", "", 16,
                 "[0.0005, 0.0]");
  // An inclined edge.
  {
    const std::string message = [&] {
      try {
        discretise(test::scene_from_yaml(
            "name: t\nmaterials:\n  m: {E: 1.0e9, nu: 0.3, thickness: 1.0e-3}\n"
            "discretization: {spacing: 1.0e-3}\nbodies:\n"
            "  plate: {material: m, polygon: [[0, 0], [0.02, 0], [0.02, 0.02], [0.01, 0.03], [0, 0.02]]}\n"
            "boundary:\n  - {body: plate, edge: 2, mirror: true, ux: 0}\n"
            "  - {body: plate, edge: 0, uy: 0}\n"));
      } catch (const InputError& e) {
        return std::string(e.what());
      }
      return std::string();
    }();
    EXPECT_NE(message.find("parallel to x or y"), std::string::npos) << message;
  }
}

// The force a mirror grip transmits (QuasiStaticProblem::reaction, summary.json
// reaction_<k>_x/y) on a tension plate 100 mm x 100 mm at dx = 2 mm, strain 1e-3: the
// continuum's E eps H t, within 0.2% (measured 2026-11-24: -0.12% here and -0.03% at
// dx = 1 mm: the free edges' skin, a band of width ~delta = 6% of the section at 2 mm);
// the two grips balance to round-off and transmit no shear (frictionless platens, 1e-9 of
// the axial force).
TEST(Mirror, GripForceIsTheUniaxialStressTimesTheSection) {
  test::PlateSpec spec;
  spec.nx = spec.ny = 50;
  spec.dx = 2e-3;
  spec.E = 70e9;
  spec.nu = 0.33;
  spec.kinematics = "small";
  spec.solver = "  linear: cholmod\n  newton: {rtol: 1.0e-12}\n";
  spec.boundary = test::mirror_tension_boundary(1e-3, spec);
  auto s = test::solve_scene(test::plate_yaml(spec));
  ASSERT_TRUE(s->run.completed) << s->run.message;
  const double expected = 70e9 * 1e-3 * 0.1 * 1e-3;
  const Vec2 left = s->problem->reaction(0), right = s->problem->reaction(1);
  std::printf("grip forces: left (%.6f, %.3e) N, right (%.6f, %.3e) N; E eps H t = %.1f N\n", left.x(), left.y(),
              right.x(), right.y(), expected);
  EXPECT_NEAR(right.x() / expected, 1.0, 2e-3);
  EXPECT_NEAR(left.x() + right.x(), 0.0, 1e-9 * expected);
  EXPECT_LT(std::abs(left.y()) + std::abs(right.y()), 1e-9 * expected);
}

// A bond that reaches the failure criterion inside the reflected depth stops the run with
// the reason (exit code 3 from `peristat run`), not with an asymmetric answer: a uniform
// stretch over s_c breaks bonds everywhere, the mirrored zone included.
TEST(Mirror, BreakingInTheReflectedDepthStopsTheRun) {
  test::PlateSpec spec = mirror_plate("  - {body: plate, edge: left, mirror: true, ux: 0}\n"
                                      "  - {body: plate, edge: right, mirror: true, ux: 1.6e-4}\n"
                                      "  - {body: plate, region: {min: [0, 0.005], max: [0.001, 0.007]}, uy: 0}\n");
  spec.kinematics = "small";
  spec.solver = "  linear: cholmod\n";
  auto s = test::solve_scene(test::plate_yaml(spec) + "failure: {criterion: stretch, G_c: 1.0e-3}\n");
  EXPECT_FALSE(s->run.completed);
  EXPECT_NE(s->run.message.find("within the reflected depth of a mirror edge"), std::string::npos)
      << s->run.message;
}

}  // namespace
}  // namespace peristat
