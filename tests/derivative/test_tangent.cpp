// Finite-difference checks of the assembled residual and tangent (the project's
// habit: "prove every tangent"). A deformed, pre-cracked plate; random states and directions.
#include <random>

#include <gtest/gtest.h>

#include "app/setup.hpp"
#include "assembly/quasi_static.hpp"
#include "support/finite_difference.hpp"
#include "support/scenes.hpp"
#include "support/solve.hpp"

namespace peristat {
namespace {

struct Fixture {
  Scene scene;
  Model model;
  std::unique_ptr<QuasiStaticProblem> problem;
};

std::unique_ptr<Fixture> cracked_plate(const std::string& kinematics, const std::string& extra = "",
                                       const std::string& correction = "") {
  test::PlateSpec spec;
  spec.surface_correction = correction;
  spec.nx = 14;
  spec.ny = 10;
  spec.kinematics = kinematics;
  spec.boundary = "  - {body: plate, edge: left, ux: 0, uy: 0}\n  - {body: plate, edge: right, ux: 2.0e-5}\n";
  spec.cracks = "  - {from: [0.004, 0.0031], to: [0.0095, 0.0072]}\n";
  auto f = std::make_unique<Fixture>();
  f->scene = test::scene_from_yaml(test::plate_yaml(spec) + extra);
  f->model = discretise(f->scene);
  f->problem = std::make_unique<QuasiStaticProblem>(f->model, problem_options(f->scene));
  f->problem->set_load_factor(1.0);
  return f;
}

using test::random_vector;

// Column-by-column central differences of the residual against the assembled tangent.
// Tolerance 1e-6 of the largest entry: the central-difference truncation error with
// h = 1e-7 dx is O(h^2 |r'''|), about 1e-9 relative here, and round-off is ~1e-9.
void check_tangent(QuasiStaticProblem& problem, const VectorXd& x, double h) {
  const test::FiniteDifferenceCheck fd = test::check_tangent(problem, x, h);
  EXPECT_LT(fd.worst, 1e-6) << fd;
  // The tangent is the Hessian of an energy, hence symmetric to round-off.
  const Eigen::MatrixXd& K = fd.jacobian;
  EXPECT_LT((K - K.transpose()).cwiseAbs().maxCoeff() / fd.scale, 1e-12);
}

TEST(Tangent, FiniteKinematicsMatchesFiniteDifferences) {
  auto f = cracked_plate("finite");
  const double dx = f->scene.discretization.spacing;
  for (unsigned seed : {1u, 2u}) {
    // Displacements up to 5% of dx: strains of a few percent, so the geometric part matters.
    const VectorXd x = random_vector(f->problem->n_unknowns(), 0.05 * dx, seed);
    check_tangent(*f->problem, x, 1e-7 * dx);
  }
}

TEST(Tangent, SmallKinematicsMatchesFiniteDifferences) {
  auto f = cracked_plate("small");
  const double dx = f->scene.discretization.spacing;
  const VectorXd x = random_vector(f->problem->n_unknowns(), 0.05 * dx, 3u);
  check_tangent(*f->problem, x, 1e-7 * dx);
}

// Bonds broken during the run (weights set to zero, the weighted volume kept at its
// reference value) leave a consistent tangent: the same check after a round of breaking at
// a random state that puts a few hundred bonds over a small critical stretch.
TEST(Tangent, ConsistentAfterBondsBreak) {
  for (const char* kin : {"finite", "small"}) {
    auto f = cracked_plate(kin, "failure: {criterion: stretch, G_c: 1.0e-3}\n");
    const double dx = f->scene.discretization.spacing;
    const VectorXd x0 = random_vector(f->problem->n_unknowns(), 0.05 * dx, 11u);
    const Index broken = f->problem->advance_irreversible_state(x0, 300);
    ASSERT_GT(broken, 50) << kin;
    const VectorXd x = random_vector(f->problem->n_unknowns(), 0.05 * dx, 12u);
    check_tangent(*f->problem, x, 1e-7 * dx);
  }
}

// The residual is the gradient of the total energy: r . v = dPi/dt (x + t v) by central
// differences in t, relative tolerance 1e-7 (truncation O(h^2), h = 1e-6 relative).
TEST(Tangent, ResidualIsTheEnergyGradient) {
  for (const char* kin : {"finite", "small"}) {
    auto f = cracked_plate(kin);
    const double dx = f->scene.discretization.spacing;
    const Index n = f->problem->n_unknowns();
    const VectorXd x = random_vector(n, 0.05 * dx, 7u);
    const VectorXd v = random_vector(n, 1.0, 8u);
    VectorXd r;
    f->problem->evaluate(x, r, nullptr);
    const Eigen::MatrixXd slope = Eigen::MatrixXd::Constant(1, 1, r.dot(v));
    const auto energy_along_v = [&](const VectorXd& t, VectorXd& e) {
      VectorXd scratch;
      f->problem->evaluate(x + t[0] * v, scratch, nullptr);
      e = VectorXd::Constant(1, f->problem->energy());
    };
    const test::FiniteDifferenceCheck fd =
        test::check_jacobian(energy_along_v, VectorXd::Zero(1), 1e-6 * dx, slope);
    EXPECT_LT(fd.worst, 1e-7) << kin << fd;
  }
}

}  // namespace
}  // namespace peristat

namespace peristat {
namespace {

// The surface correction (issue 13) changes the bond weights of the families near edges and
// crack faces, not the form of the energy: the same finite-difference checks hold with it,
// in both kinematics, before and after bonds break (the factors of the families that lost
// bonds are computed again).
TEST(Tangent, SurfaceCorrectedMatchesFiniteDifferences) {
  for (const char* kin : {"finite", "small"}) {
    auto f = cracked_plate(kin, "", "moments");
    ASSERT_GT(f->problem->surface_correction().stats().corrected, 50) << kin;
    const double dx = f->scene.discretization.spacing;
    const VectorXd x = random_vector(f->problem->n_unknowns(), 0.05 * dx, 21u);
    check_tangent(*f->problem, x, 1e-7 * dx);
  }
}

TEST(Tangent, SurfaceCorrectedConsistentAfterBondsBreak) {
  for (const char* kin : {"finite", "small"}) {
    auto f = cracked_plate(kin, "failure: {criterion: stretch, G_c: 1.0e-3}\n", "moments");
    const double dx = f->scene.discretization.spacing;
    const std::vector<double> before = f->problem->surface_correction().bond_weights();
    const VectorXd x0 = random_vector(f->problem->n_unknowns(), 0.05 * dx, 11u);
    const Index broken = f->problem->advance_irreversible_state(x0, 300);
    ASSERT_GT(broken, 50) << kin;
    // Not vacuous: intact bonds of the families that lost bonds changed their weight.
    const std::vector<double> after = f->problem->surface_correction().bond_weights();
    Index changed = 0;
    for (std::size_t b = 0; b < before.size(); ++b) changed += after[b] != 0.0 && after[b] != before[b];
    EXPECT_GT(changed, 100) << kin;
    const VectorXd x = random_vector(f->problem->n_unknowns(), 0.05 * dx, 12u);
    check_tangent(*f->problem, x, 1e-7 * dx);
    // Undoing the round restores the factors exactly.
    f->problem->revert_irreversible_state();
    const std::vector<double> restored = f->problem->surface_correction().bond_weights();
    EXPECT_TRUE(std::equal(before.begin(), before.end(), restored.begin())) << kin;
  }
}

}  // namespace
}  // namespace peristat

namespace peristat {
namespace {

// Mirror grips (docs/theory/osb.md, section 7): the ghosts' displacements are functions of
// their images', so the columns of a source particle gather the ghosts' columns with the
// reflection's signs. The same finite-difference checks hold, and the folded tangent stays
// symmetric: the reflected layers make every block (i, ghost of m) the mirror of
// (m, ghost of i). A state that is not symmetric about the edges (random), both kinematics,
// with and without the surface correction.
TEST(Tangent, MirrorGripsMatchFiniteDifferences) {
  for (const char* kin : {"finite", "small"})
    for (const char* correction : {"moments", "none"}) {
      test::PlateSpec spec;
      spec.nx = 18;
      spec.ny = 10;
      spec.kinematics = kin;
      spec.surface_correction = correction;
      spec.boundary = "  - {body: plate, edge: left, mirror: true, ux: 0}\n"
                      "  - {body: plate, edge: right, mirror: true, ux: 2.0e-5}\n"
                      "  - {body: plate, region: {min: [0, 0.004], max: [0.001, 0.006]}, uy: 0}\n";
      const Scene scene = test::scene_from_yaml(test::plate_yaml(spec));
      const Model model = discretise(scene);
      ASSERT_EQ(model.constraints.images.size(), 2u * 8u * 10u);
      QuasiStaticProblem problem(model, problem_options(scene));
      problem.set_load_factor(1.0);
      const double dx = scene.discretization.spacing;
      const VectorXd x = random_vector(problem.n_unknowns(), 0.05 * dx, 31u);
      SCOPED_TRACE(std::string(kin) + ", " + correction);
      check_tangent(problem, x, 1e-7 * dx);
    }
}

}  // namespace
}  // namespace peristat
