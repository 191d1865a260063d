// Pre-cracks through lattice points (docs/theory/osb.md, "Pre-cracks"): a crack drawn along a
// row, a diagonal or another lattice direction, or with its tips where bonds pass, cuts the
// bonds its exact geometry cuts. The coordinates of lattice points and crack ends are decimals
// that binary floating point rounds (dx = 1 mm), so "exactly on the line" is, in the computed
// numbers, within round-off of it on either side; the cut set must not depend on which.
#include <array>
#include <cmath>
#include <cstdint>
#include <string>

#include <gtest/gtest.h>

#include "discretisation/model.hpp"
#include "support/scenes.hpp"

namespace peristat {
namespace {

using I2 = std::array<std::int64_t, 2>;

std::int64_t cross(const I2& u, const I2& v) { return u[0] * v[1] - u[1] * v[0]; }
std::int64_t dot(const I2& u, const I2& v) { return u[0] * v[0] + u[1] * v[1]; }
I2 minus(const I2& u, const I2& v) { return {u[0] - v[0], u[1] - v[1]}; }

/// The rule of docs/theory/osb.md in exact integer arithmetic: a bond [p, q] is cut when p and
/// q are on different sides of the crack line (a point on it counts as left, cross >= 0) and
/// the crossing lies on the closed segment [a, b].
bool exactly_cut(const I2& p, const I2& q, const I2& a, const I2& b) {
  const I2 d = minus(b, a);
  const std::int64_t cp = cross(d, minus(p, a)), cq = cross(d, minus(q, a));
  if ((cp >= 0) == (cq >= 0)) return false;
  // The crossing x = p + (q - p) cp / (cp - cq); (x - a).d = num / den.
  std::int64_t den = cp - cq, num = dot(minus(p, a), d) * den + dot(minus(q, p), d) * cp;
  if (den < 0) num = -num, den = -den;
  return num >= 0 && num <= dot(d, d) * den;
}

/// A point in units of dx / 2: lattice points (i + 1/2) dx are odd, their midpoints even.
I2 half_steps(double x, double y, double dx) {
  const I2 h{std::llround(2.0 * x / dx), std::llround(2.0 * y / dx)};
  EXPECT_NEAR(2.0 * x / dx, double(h[0]), 1e-9) << "a point of the test is not on the half lattice";
  EXPECT_NEAR(2.0 * y / dx, double(h[1]), 1e-9) << "a point of the test is not on the half lattice";
  return h;
}

struct Case {
  const char* what;
  std::array<double, 4> crack;  // from x, y, to x, y [m]
};

// Lattice points are at (i + 0.5) mm. Every crack below passes through lattice points or has
// bonds through its tips, and the rounding of its decimals puts some of those points a few
// 1e-19 m to either side of the computed line.
const Case kCases[] = {
    {"along a row, tips on particles", {0.0055, 0.0105, 0.0215, 0.0105}},
    {"along a column, tips on particles", {0.0125, 0.0035, 0.0125, 0.0165}},
    {"45 degrees, tips on particles", {0.0035, 0.0025, 0.0165, 0.0155}},
    {"-45 degrees, tips between particles", {0.004, 0.017, 0.016, 0.005}},
    {"slope 1/2, tips on particles", {0.0035, 0.0055, 0.0235, 0.0155}},
    {"slope -3, tips on particles", {0.0105, 0.0185, 0.0145, 0.0065}},
    {"between rows, tips where diagonal bonds cross", {0.007, 0.011, 0.019, 0.011}},
};

TEST(PreCrack, ALineThroughLatticePointsCutsTheBondsItsExactGeometryCuts) {
  for (const Case& c : kCases) {
    SCOPED_TRACE(c.what);
    test::PlateSpec spec;
    spec.nx = 28;
    spec.ny = 22;
    spec.boundary = "  - {body: plate, edge: left, ux: 0, uy: 0}\n";
    spec.cracks = "  - {from: [" + std::to_string(c.crack[0]) + ", " + std::to_string(c.crack[1]) + "], to: [" +
                  std::to_string(c.crack[2]) + ", " + std::to_string(c.crack[3]) + "]}\n";
    const Model model = discretise(test::scene_from_yaml(test::plate_yaml(spec)));
    const Particles& p = model.particles;
    const I2 a = half_steps(c.crack[0], c.crack[1], spec.dx), b = half_steps(c.crack[2], c.crack[3], spec.dx);
    const auto at = [&](Index i) { return half_steps(p.position[i].x(), p.position[i].y(), spec.dx); };
    // Every bond the model kept is uncut exactly, and the model cut as many as the exact rule:
    // so the two sets are the same.
    std::int64_t exact = 0, on_line = 0;
    for (Index i = 0; i < p.size(); ++i) {
      const I2 x = at(i);
      if (cross(minus(b, a), minus(x, a)) == 0) ++on_line;
      for (Index k = model.bonds.start[i]; k < model.bonds.start[i + 1]; ++k)
        ASSERT_FALSE(exactly_cut(x, at(model.bonds.neighbour[k]), a, b))
            << "the bond from particle " << i << " to " << model.bonds.neighbour[k] << " crosses the crack";
      for (const auto& o : model.stencil.offset) {
        const Index j = model.lattice_index.at(p.lattice[i][0] + o[0], p.lattice[i][1] + o[1]);
        if (j > i && p.body[j] == p.body[i] && exactly_cut(x, at(j), a, b)) ++exact;
      }
    }
    EXPECT_GT(exact, 0);
    EXPECT_EQ(model.n_cut_bonds, exact);
    if (std::string(c.what).find("on particles") != std::string::npos) {
      EXPECT_GE(on_line, 4);
    }
  }
}

}  // namespace
}  // namespace peristat
