// The parallel assembly is deterministic: one thread and two threads give bit-identical
// residuals and tangents (each entry is summed by one thread in a fixed order).
#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <functional>
#include <limits>
#include <random>
#include <tuple>

#include <gtest/gtest.h>
#include <omp.h>

#include "app/setup.hpp"
#include "assembly/quasi_static.hpp"
#include "materials/osb.hpp"
#include "materials/surface_correction.hpp"
#include "parallel/thread_ranks.hpp"
#include "support/finite_difference.hpp"
#include "support/owners.hpp"
#include "support/scenes.hpp"
#include "support/solve.hpp"

namespace peristat {
namespace {

/// A 24 x 14 plate pulled at its right edge, with an inclined crack (the default surface
/// correction: the families it cuts keep their own weights).
Scene pulled_cracked_plate() {
  test::PlateSpec spec;
  spec.nx = 24;
  spec.ny = 14;
  spec.boundary = "  - {body: plate, edge: left, ux: 0, uy: 0}\n  - {body: plate, edge: right, ux: 1.0e-5}\n";
  spec.cracks = "  - {from: [0.008, 0.004], to: [0.014, 0.01]}\n";
  return test::scene_from_yaml(test::plate_yaml(spec));
}

/// Unknowns drawn uniformly from +-1e-5 m (strains of about 1e-2: every bond's kinematics matters).
VectorXd random_state(Index n, unsigned seed) {
  std::mt19937 gen(seed);
  std::uniform_real_distribution<double> d(-1e-5, 1e-5);
  VectorXd x(n);
  for (Index i = 0; i < n; ++i) x[i] = d(gen);
  return x;
}

TEST(Assembly, BitIdenticalForAnyThreadCount) {
  const Scene scene = pulled_cracked_plate();
  const Model model = discretise(scene);
  QuasiStaticProblem problem(model, problem_options(scene));
  problem.set_load_factor(1.0);
  const VectorXd x = random_state(problem.n_unknowns(), 5);

  const int saved = omp_get_max_threads();
  SparseMatrix K1 = problem.make_tangent(), K2 = problem.make_tangent();
  SparseMatrix P1 = problem.make_preconditioner(), P2 = problem.make_preconditioner();
  VectorXd r1, r2;
  omp_set_num_threads(1);
  problem.evaluate(x, r1, &K1);
  problem.assemble_preconditioner(P1);
  omp_set_num_threads(2);
  problem.evaluate(x, r2, &K2);
  problem.assemble_preconditioner(P2);
  omp_set_num_threads(saved);

  ASSERT_EQ(K1.nonZeros(), K2.nonZeros());
  EXPECT_TRUE((r1.array() == r2.array()).all());
  EXPECT_TRUE(std::equal(K1.valuePtr(), K1.valuePtr() + K1.nonZeros(), K2.valuePtr()));
  EXPECT_TRUE(std::equal(P1.valuePtr(), P1.valuePtr() + P1.nonZeros(), P2.valuePtr()));
  EXPECT_GT(r1.norm(), 0.0);  // a non-trivial state
}

// The force gather does not keep the kernel's bond forces: it evaluates each bond again, once
// for both of its families, from bond_kinematics() and each family's BondForceLaw. That gives
// the kernel's bits only if (a) the law reproduces the kernel's t_b M_b exactly and (b) the
// reverse bond (-xi, -eta) has the direction -M and the same length and extension exactly.
// Both are asserted with ==: no tolerance, since a last-bit difference would make the residual
// depend on which family's copy is read. Random families, finite and small kinematics.
TEST(Assembly, ForceLawAndReverseKinematicsGiveTheKernelsBondForcesBitForBit) {
  std::mt19937 gen(11);
  std::uniform_real_distribution<double> unit(-1.0, 1.0), weight(0.2, 1.5);
  for (const Kinematics kinematics : {Kinematics::finite, Kinematics::small}) {
    Material material;
    material.E = 192e9;
    material.nu = 1.0 / 3.0;
    material.kinematics = kinematics;
    const OsbConstants constants = OsbConstants::from(material);
    const bool finite = kinematics == Kinematics::finite;
    for (int trial = 0; trial < 20; ++trial) {
      const std::size_t n = 28;
      std::vector<Vec2> xi(n), eta(n), force(n), s(n);
      std::vector<double> w(n), extension(n);
      std::vector<BondStiffness> k(n);
      for (std::size_t b = 0; b < n; ++b) {
        xi[b] = 1e-3 * Vec2(3.0 * unit(gen), 3.0 * unit(gen));
        if (xi[b].norm() < 1e-4) xi[b] = Vec2(1e-3, 0.0);
        eta[b] = 1e-6 * Vec2(unit(gen), unit(gen));
        w[b] = trial % 3 == 0 && b % 5 == 0 ? 0.0 : 1e-6 * weight(gen);  // some bonds broken
      }
      const FamilyResult res = osb_family(constants, weighted_volume(xi, w), xi, w, eta,
                                          FamilyOutputs{force, extension, s, k}, true);
      for (std::size_t b = 0; b < n; ++b) {
        const BondKinematics kin = bond_kinematics(finite, xi[b], eta[b]);
        const Vec2 gathered = res.law.t(w[b], kin.x, kin.e) * kin.M;
        EXPECT_EQ(gathered.x(), force[b].x()) << "bond " << b;
        EXPECT_EQ(gathered.y(), force[b].y()) << "bond " << b;
        const BondKinematics reverse = bond_kinematics(finite, Vec2(-xi[b]), Vec2(-eta[b]));
        EXPECT_EQ(reverse.x, kin.x);
        EXPECT_EQ(reverse.e, kin.e);
        EXPECT_EQ(reverse.M.x(), -kin.M.x());
        EXPECT_EQ(reverse.M.y(), -kin.M.y());
      }
      EXPECT_GT(std::abs(res.law.p) + std::abs(res.law.alpha), 0.0);  // a non-trivial law
    }
  }
}

// The same at the level of the problem: the internal forces of evaluate() are, bit for bit,
// what summing every family kernel's own t_b M_b gives (the forces of the families of q and of
// its neighbours, in q's bond order: dPi/du_q = sum_b V_j t_r M_r - V_q t_b M_b), computed here
// independently of the gather, from osb_family and a surface correction of the scene's kind.
// A cracked plate with the surface correction (families with their own weights) at a random
// state; exact equality, since the gather claims the kernel's bits.
TEST(Assembly, GatheredForcesAreTheKernelsForcesBitForBit) {
  const Scene scene = pulled_cracked_plate();
  const Model model = discretise(scene);
  const ProblemOptions options = problem_options(scene);
  QuasiStaticProblem problem(model, options);
  problem.set_load_factor(1.0);
  const VectorXd x = random_state(problem.n_unknowns(), 3);
  VectorXd r, u;
  problem.evaluate(x, r, nullptr);
  problem.expand(x, u);

  const SurfaceCorrection correction(model, options.surface_correction);
  ASSERT_GT(correction.stats().corrected, 0);
  const OsbConstants constants = OsbConstants::from(model.bodies[0].material);
  const Bonds& bonds = model.bonds;
  const Particles& p = model.particles;
  std::vector<Vec2> force(static_cast<std::size_t>(bonds.n_bonds()));
  for (Index i = 0; i < p.size(); ++i) {
    const Index b0 = bonds.start[i], nb = bonds.family_size(i);
    std::vector<Vec2> eta(nb), s(nb);
    std::vector<double> extension(nb);
    std::vector<BondStiffness> k(nb);
    for (Index b = b0; b < b0 + nb; ++b) {
      const Index j = bonds.neighbour[b];
      eta[b - b0] = Vec2(u[2 * j], u[2 * j + 1]) - Vec2(u[2 * i], u[2 * i + 1]);
    }
    osb_family(constants, correction.weighted_volume()[i], model.family_xi(i), correction.family_weights(i),
               eta, FamilyOutputs{std::span(force).subspan(b0, nb), extension, s, k}, false);
  }
  const VectorXd& gathered = problem.internal_force();
  Index compared = 0;
  for (Index q = 0; q < p.size(); ++q) {
    Vec2 f = Vec2::Zero();
    for (Index b = bonds.start[q]; b < bonds.start[q + 1]; ++b)
      f += p.volume[bonds.neighbour[b]] * force[bonds.reverse(q, b)] - p.volume[q] * force[b];
    EXPECT_EQ(gathered[2 * q], f.x()) << "particle " << q;
    EXPECT_EQ(gathered[2 * q + 1], f.y()) << "particle " << q;
    compared += f.norm() > 0.0;
  }
  EXPECT_GT(compared, p.size() / 2);  // a non-trivial state
}

// The second make_tangent() rebuilds the same pattern the first one handed over.
// A bond's stiffness is kept as (axial, transverse) and its direction taken from s_b = b_b M_b
// (FamilyOutputs): bond_block() must give axial M M^T + transverse (I - M M^T) for any
// positive b_b and direction, to rounding (1e-15 of the largest coefficient: a handful of
// products of numbers of order one), and a bond without weight (s_b = 0) no axial part.
TEST(Assembly, BondBlockIsTheCentralForceStiffnessAlongS) {
  std::mt19937 gen(7);
  std::uniform_real_distribution<double> angle(0.0, 6.283185307179586), scale(1e-3, 1e3);
  for (int trial = 0; trial < 100; ++trial) {
    const double phi = angle(gen), a = scale(gen), g = scale(gen) - 500.0, b = scale(gen);
    const Vec2 M(std::cos(phi), std::sin(phi));
    const Mat2 expected = a * M * M.transpose() + g * (Mat2::Identity() - M * M.transpose());
    const Sym2 k = bond_block(BondStiffness{a, g}, b * M);
    const double tolerance = 1e-15 * 4.0 * std::max(std::abs(a), std::abs(g));
    EXPECT_NEAR(k[0], expected(0, 0), tolerance);
    EXPECT_NEAR(k[1], expected(0, 1), tolerance);
    EXPECT_NEAR(k[2], expected(1, 1), tolerance);
  }
  const Sym2 none = bond_block(BondStiffness{0.0, 0.0}, Vec2::Zero());
  EXPECT_EQ(none[0], 0.0);
  EXPECT_EQ(none[1], 0.0);
  EXPECT_EQ(none[2], 0.0);
}

TEST(Assembly, RebuiltPatternEqualsTheFirst) {
  test::PlateSpec spec;
  spec.nx = 10;
  spec.ny = 8;
  spec.boundary = "  - {body: plate, edge: left, ux: 0, uy: 0}\n";
  const Scene scene = test::scene_from_yaml(test::plate_yaml(spec));
  const Model model = discretise(scene);
  QuasiStaticProblem problem(model, problem_options(scene));
  const SparseMatrix a = problem.make_tangent(), b = problem.make_tangent();
  ASSERT_EQ(a.nonZeros(), b.nonZeros());
  EXPECT_TRUE(std::equal(a.innerIndexPtr(), a.innerIndexPtr() + a.nonZeros(), b.innerIndexPtr()));
  EXPECT_TRUE(std::equal(a.outerIndexPtr(), a.outerIndexPtr() + a.outerSize() + 1, b.outerIndexPtr()));
}

// The `block` selector adds fictitious particles at the free lattice points of its box (the
// paper's fixed 3 x 3 corner block of case 4.4) and refuses a box that reaches into a body.
TEST(Discretise, ABondThroughACrackTipIsCutBothWaysOrNeither) {
  // The bond from (5.5, 5.5) mm to (4.5, 7.5) mm passes exactly through the crack's tip
  // (5.1, 6.3) mm. Computed from each end, round-off put the crossing on either side of the
  // tip: the bond was cut in one direction only and the other's reverse named a wrong bond
  // (found by unit.ModelPart). The test is exact: a property of the geometry, not of a tolerance.
  const Vec2 p(0.0055, 0.0055), q(0.0045, 0.0075), a(0.0051, 0.0063), b(0.0187, 0.0297);
  EXPECT_EQ(bond_crosses_crack(p, q, a, b), bond_crosses_crack(q, p, a, b));
  EXPECT_EQ(bond_crosses_crack(p, q, b, a), bond_crosses_crack(q, p, b, a));
  test::PlateSpec spec;
  spec.nx = 24;
  spec.ny = 36;
  spec.boundary = "  - {body: plate, edge: left, ux: 0, uy: 0}\n";
  spec.cracks = "  - {from: [0.0051, 0.0063], to: [0.0187, 0.0297]}\n";
  const Model model = discretise(test::scene_from_yaml(test::plate_yaml(spec)));
  ASSERT_GT(model.n_cut_bonds, 0);
  const Bonds& bonds = model.bonds;
  for (Index i = 0; i < model.particles.size(); ++i)
    for (Index k = bonds.start[i]; k < bonds.start[i + 1]; ++k) {
      const Index r = bonds.reverse(i, k);
      ASSERT_GE(r, 0);
      ASSERT_EQ(bonds.neighbour[r], i) << "the reverse of bond " << k << " ends at its particle";
      ASSERT_EQ(bonds.reverse(bonds.neighbour[k], r), k);
    }
}

// Each bond's weight is the stencil's weight of its lattice offset (found here from the two
// particles' lattice points, not from the storage); the families with every stencil bond read
// the stencil's weights themselves, and only the others keep weights of their own: on this
// cracked plate with a clamped edge both kinds occur, and the own weights are a minority.
TEST(Discretise, BondWeightsAreTheStencilsAndOnlyCutFamiliesStoreTheirOwn) {
  test::PlateSpec spec;
  spec.nx = 30;
  spec.ny = 24;
  spec.boundary = "  - {body: plate, edge: left, ux: 0, uy: 0}\n";
  spec.cracks = "  - {from: [0.008, 0.012], to: [0.02, 0.012]}\n";
  const Model model = discretise(test::scene_from_yaml(test::plate_yaml(spec)));
  const Bonds& bonds = model.bonds;
  const Stencil& st = model.stencil;
  ASSERT_GT(model.n_cut_bonds, 0);
  Index whole = 0, cut = 0;
  for (Index i = 0; i < model.particles.size(); ++i) {
    const auto& li = model.particles.lattice[i];
    for (Index b = bonds.start[i]; b < bonds.start[i + 1]; ++b) {
      const auto& lj = model.particles.lattice[bonds.neighbour[b]];
      const auto k =
          std::find(st.offset.begin(), st.offset.end(), std::array<int, 2>{lj[0] - li[0], lj[1] - li[1]});
      ASSERT_NE(k, st.offset.end());
      ASSERT_EQ(bonds.weight(i, b), st.weight[static_cast<std::size_t>(k - st.offset.begin())])
          << "bond " << b;
    }
    const bool complete = static_cast<std::size_t>(bonds.family_size(i)) == st.offset.size();
    EXPECT_EQ(bonds.weights(i).data() == bonds.stencil_weight.data(), complete) << "particle " << i;
    (complete ? whole : cut) += 1;
  }
  ASSERT_GT(whole, 0);
  ASSERT_GT(cut, 0);
  EXPECT_LT(bonds.own_weight.size(), static_cast<std::size_t>(bonds.n_bonds()) / 2);
  const std::vector<double> all = bonds.every_weight();
  ASSERT_EQ(all.size(), static_cast<std::size_t>(bonds.n_bonds()));
  for (Index i = 0; i < model.particles.size(); ++i)
    for (Index b = bonds.start[i]; b < bonds.start[i + 1]; ++b) ASSERT_EQ(all[b], bonds.weight(i, b));
}

TEST(Discretise, BlockSelectorAddsTheFreeLatticePointsOfItsBox) {
  test::PlateSpec spec;
  spec.nx = 10;
  spec.ny = 8;  // plate [0, 0.01] x [0, 0.008], lattice points at (i + 1/2) mm
  spec.boundary =
      "  - {body: plate, edge: bottom, uy: 0}\n"
      "  - {body: plate, block: {min: [0.010, -0.003], max: [0.013, 0.0]}, ux: 0, uy: 0}\n";
  const Scene scene = test::scene_from_yaml(test::plate_yaml(spec));
  const Model model = discretise(scene);
  const Particles& p = model.particles;
  int in_block = 0;
  for (Index q = 0; q < p.size(); ++q) {
    if (p.position[q].x() > 0.010 && p.position[q].y() < 0.0) {
      ++in_block;
      EXPECT_TRUE(p.fictitious[q]);
      EXPECT_TRUE(model.constraints.prescribed[2 * q] && model.constraints.prescribed[2 * q + 1]);
    }
  }
  EXPECT_EQ(in_block, 9);  // x = 10.5, 11.5, 12.5 mm; y = -0.5, -1.5, -2.5 mm

  spec.boundary = "  - {body: plate, block: {min: [0.008, -0.003], max: [0.013, 0.0015]}, ux: 0}\n";
  EXPECT_THROW(discretise(test::scene_from_yaml(test::plate_yaml(spec))), InputError);
}

}  // namespace
}  // namespace peristat
