// The moments surface correction (docs/theory/osb.md, section 8): each family's energy
// density for a homogeneous deformation is the interior one, wherever the family was cut.
#include <gtest/gtest.h>

#include <vector>

#include "discretisation/model.hpp"
#include "materials/osb.hpp"
#include "materials/surface_correction.hpp"
#include "support/scenes.hpp"

namespace peristat {
namespace {

Model cracked_model(const std::string& correction) {
  test::PlateSpec spec;
  spec.nx = 16;
  spec.ny = 12;
  spec.surface_correction = correction;
  spec.kinematics = "small";
  spec.boundary = "  - {body: plate, edge: left, ux: 0}\n";
  spec.cracks = "  - {from: [0.004, 0.0031], to: [0.0095, 0.0072]}\n";
  return discretise(test::scene_from_yaml(test::plate_yaml(spec)));
}

/// Energy density of family i under the homogeneous small strain eps (eta_b = eps xi_b).
double family_energy(const Model& model, const SurfaceCorrection& sc, Index i, const Mat2& eps) {
  const Index nb = model.bonds.family_size(i);
  std::vector<Vec2> eta(nb), force(nb), s(nb);
  std::vector<double> extension(nb);
  std::vector<BondStiffness> k(nb);
  const std::span<const Vec2> xi = model.family_xi(i);
  for (Index b = 0; b < nb; ++b) eta[b] = eps * xi[b];
  const OsbConstants c = OsbConstants::from(model.bodies[0].material);
  return osb_family(c, sc.weighted_volume()[i], xi, sc.family_weights(i), eta,
                    FamilyOutputs{force, extension, s, k}, false)
      .energy_density;
}

// Every family whose moment was matched has the interior energy density for three strain
// states (to 1e-9 relative: the match is to 1e-6 of the moment, exact up to the 5 x 5
// solve's round-off in practice). Uncorrected, the cut families miss it by percents.
TEST(SurfaceCorrection, CutFamiliesHaveTheInteriorEnergy) {
  const Model model = cracked_model("moments");
  const SurfaceCorrection sc(model, SurfaceCorrectionMethod::moments);
  const SurfaceCorrection none(model, SurfaceCorrectionMethod::none);
  ASSERT_GT(sc.stats().corrected, 100);
  const Index interior = [&] {  // a particle with a complete family
    for (Index i = 0; i < model.particles.size(); ++i)
      if (static_cast<std::size_t>(model.bonds.family_size(i)) == model.stencil.offset.size()) return i;
    return Index{-1};
  }();
  ASSERT_GE(interior, 0);
  for (const Mat2& eps : {Mat2{{1e-3, 0.0}, {0.0, -3e-4}}, Mat2{{0.0, 5e-4}, {5e-4, 0.0}},
                         Mat2{{2e-4, 1e-4}, {1e-4, 7e-4}}}) {
    const double w0 = family_energy(model, sc, interior, eps);
    double worst = 0.0, worst_none = 0.0;
    Index matched = 0;
    for (Index i = 0; i < model.particles.size(); ++i) {
      double m = 0.0;
      for (Index b = model.bonds.start[i]; b < model.bonds.start[i + 1]; ++b)
        m += sc.weight(i, b) * model.xi(i, b).squaredNorm();
      // Only families the correction changed and matched: weighted volume at m0 to 1e-9.
      if (std::abs(m / sc.interior_volume() - 1.0) > 1e-9) continue;
      ++matched;
      worst = std::max(worst, std::abs(family_energy(model, sc, i, eps) / w0 - 1.0));
      worst_none = std::max(worst_none, std::abs(family_energy(model, none, i, eps) / w0 - 1.0));
    }
    EXPECT_GT(matched, model.particles.size() - 20);
    EXPECT_LT(worst, 1e-9);
    EXPECT_GT(worst_none, 0.05);  // the uncorrected cut families are far off
  }
}

// A family with every bond keeps omega = 1 exactly; the factors stay within their bounds.
TEST(SurfaceCorrection, InteriorFamiliesAreUntouched) {
  const Model model = cracked_model("moments");
  const SurfaceCorrection sc(model, SurfaceCorrectionMethod::moments);
  const Bonds& bonds = model.bonds;
  for (Index i = 0; i < model.particles.size(); ++i) {
    const bool complete = static_cast<std::size_t>(bonds.family_size(i)) == model.stencil.offset.size();
    for (Index b = bonds.start[i]; b < bonds.start[i + 1]; ++b) {
      const double omega = sc.weight(i, b) / bonds.weight(i, b);
      if (complete) {
        EXPECT_EQ(omega, 1.0);
      }
      EXPECT_GE(omega, kMinInfluence - 1e-12);
      EXPECT_LE(omega, kMaxInfluence + 1e-12);
    }
  }
}

// The interior families read the model's bond weights instead of a copy (8 bytes per bond):
// exactly the complete families share them, every cut family keeps its own factors, and
// without a correction no family needs storage of its own.
TEST(SurfaceCorrection, OnlyCutFamiliesKeepTheirOwnWeights) {
  const Model model = cracked_model("moments");
  const SurfaceCorrection sc(model, SurfaceCorrectionMethod::moments);
  const SurfaceCorrection none(model, SurfaceCorrectionMethod::none);
  const Bonds& bonds = model.bonds;
  Index complete_families = 0;
  for (Index i = 0; i < model.particles.size(); ++i) {
    const bool complete = static_cast<std::size_t>(bonds.family_size(i)) == model.stencil.offset.size();
    complete_families += complete;
    const bool shares = sc.family_weights(i).data() == bonds.weights(i).data();
    EXPECT_EQ(shares, complete) << "particle " << i;
    EXPECT_EQ(none.family_weights(i).data(), bonds.weights(i).data()) << "particle " << i;
  }
  ASSERT_GT(complete_families, 10);  // not vacuous: both kinds occur
  ASSERT_GT(sc.stats().corrected, 100);
  EXPECT_EQ(sc.own_families(), sc.stats().corrected);
  EXPECT_EQ(none.own_families(), 0);
}

}  // namespace
}  // namespace peristat

namespace peristat {
namespace {

// `layers: 0` grips the body's own outermost particles: no fictitious particle is added, the
// edge's column (or the boundary ring) is prescribed, nothing else.
TEST(SurfaceGrips, LayersZeroSelectsTheOutermostParticles) {
  test::PlateSpec spec;
  spec.nx = 10;
  spec.ny = 6;
  spec.boundary = "  - {body: plate, edge: left, layers: 0, ux: 0}\n  - {body: plate, edge: top, layers: 0, uy: 1.0e-6}\n";
  const Model edge = discretise(test::scene_from_yaml(test::plate_yaml(spec)));
  Index fictitious = 0, ux = 0, uy = 0;
  for (Index i = 0; i < edge.particles.size(); ++i) {
    fictitious += edge.particles.fictitious[i];
    const Vec2& X = edge.particles.position[i];
    const bool left = X.x() < spec.dx, top = X.y() > (spec.ny - 1) * spec.dx;
    EXPECT_EQ(bool(edge.constraints.prescribed[2 * i]), left) << X.transpose();
    EXPECT_EQ(bool(edge.constraints.prescribed[2 * i + 1]), top) << X.transpose();
    ux += edge.constraints.prescribed[2 * i];
    uy += edge.constraints.prescribed[2 * i + 1];
  }
  EXPECT_EQ(fictitious, 0);
  EXPECT_EQ(ux, spec.ny);
  EXPECT_EQ(uy, spec.nx);

  spec.boundary = "  - {body: plate, surround: true, layers: 0, ux: 0, uy: 0}\n";
  const Model ring = discretise(test::scene_from_yaml(test::plate_yaml(spec)));
  Index held = 0;
  for (Index i = 0; i < ring.particles.size(); ++i) held += ring.constraints.prescribed[2 * i];
  EXPECT_EQ(ring.particles.size(), spec.nx * spec.ny);
  EXPECT_EQ(held, 2 * spec.nx + 2 * spec.ny - 4);
}

}  // namespace
}  // namespace peristat
