// Finite-difference checks of the contact pair kernel in every state (open, on the switch-on
// ramp, fully in contact; stick; slip either way; both normal laws) and of the assembled
// tangent of a plate whose crack is closed and sheared (docs/theory/contact.md).
#include <random>

#include <gtest/gtest.h>

#include "app/setup.hpp"
#include "assembly/quasi_static.hpp"
#include "contact/contact.hpp"
#include "support/finite_difference.hpp"
#include "support/scenes.hpp"
#include "support/solve.hpp"

namespace peristat {
namespace {

constexpr double dx = 1e-3;

struct Case {
  const char* name;
  NormalLaw normal;
  double gate, friction;
  Vec2 du;  ///< relative displacement in units of dx, in the frame (t, n) of the pair
  PairStatus status;
  bool on_ramp;  ///< |Y| within the switch-on ramp distance (paper law)
};

// Central differences of g(du) against J, h = 1e-7 dx: truncation O(h^2 g''') ~ 1e-12
// relative, round-off ~1e-9 relative; tolerance 1e-6 of max |J|. Pairs with a normal at an
// odd angle so that every component of J is exercised.
TEST(ContactKernel, JacobianMatchesFiniteDifferencesInEveryState) {
  const double angle = 0.37;
  const Vec2 n(std::cos(angle), std::sin(angle)), t(-n.y(), n.x());
  ContactPair pair;
  pair.normal = n;
  pair.gap0 = dx;
  pair.stiffness = 2.5e4;
  const Vec2 X = dx * n + 0.2 * dx * t;  // reference: one spacing across, a little offset
  const double slip = 0.01 * dx;         // committed slip w_p
  const std::vector<Case> cases = {
      {"open (beyond the radius)", NormalLaw::paper, 0.1, 0.5, {0.0, 0.05}, PairStatus::open, false},
      {"open (stretched normal)", NormalLaw::paper, 0.1, 0.5, {-0.2, 0.01}, PairStatus::open, true},
      {"ramp, stick", NormalLaw::paper, 0.1, 0.5, {0.012, -0.07}, PairStatus::stick, true},
      {"ramp, slip", NormalLaw::paper, 0.1, 0.2, {0.1, -0.05}, PairStatus::slip, true},
      {"full, stick", NormalLaw::paper, 0.1, 0.5, {0.05, -0.2}, PairStatus::stick, false},
      {"full, slip +", NormalLaw::paper, 0.1, 0.3, {0.15, -0.15}, PairStatus::slip, false},
      {"full, slip -", NormalLaw::paper, 0.1, 0.3, {-0.5, -0.15}, PairStatus::slip, false},
      {"sharp gate, slip", NormalLaw::paper, 0.0, 0.3, {-0.4, -0.1}, PairStatus::slip, false},
      {"frictionless", NormalLaw::paper, 0.1, 0.0, {-0.4, -0.15}, PairStatus::slip, false},
      {"pair law, stick", NormalLaw::pair, 0.0, 0.5, {0.05, -0.1}, PairStatus::stick, false},
      {"pair law, slip", NormalLaw::pair, 0.0, 0.2, {0.3, -0.2}, PairStatus::slip, false},
      {"pair law, open", NormalLaw::pair, 0.0, 0.5, {0.1, 0.1}, PairStatus::open, false},
  };
  for (const Case& c : cases) {
    ContactLaw law;
    law.normal = c.normal;
    law.radius = 1.05 * dx;
    law.gate = c.gate;
    law.friction = c.friction;
    law.tangential_factor = 1.0;
    const Vec2 du = dx * (c.du.x() * t + c.du.y() * n);
    const PairResult r = contact_pair(pair, X, du, PairHistory{slip}, law, true);
    ASSERT_EQ(r.status, c.status) << c.name;
    const double dist = (X + du).norm();
    const bool ramp = c.gate > 0.0 && dist > (1.0 - c.gate) * law.radius && dist < law.radius;
    ASSERT_EQ(ramp, c.on_ramp) << c.name << ": |Y| = " << dist / dx << " dx";
    if (r.status == PairStatus::open) {
      EXPECT_EQ(r.g.norm(), 0.0) << c.name;
      EXPECT_EQ(r.J.norm(), 0.0) << c.name;
      continue;
    }
    // Coulomb's law holds: |tau| <= f_c F_n, with equality in slip.
    if (r.status == PairStatus::slip) {
      EXPECT_NEAR(std::abs(r.tangential), c.friction * r.normal_force, 1e-12);
    } else {
      EXPECT_LE(std::abs(r.tangential), c.friction * r.normal_force);
    }
    // g(du + d) for d = +-h e_k, remembering whether a perturbed state left the pair's state.
    bool crosses_kink = false;
    const auto g = [&](const VectorXd& d, VectorXd& out) {
      const PairResult q = contact_pair(pair, X, du + Vec2(d), PairHistory{slip}, law, false);
      crosses_kink = crosses_kink || q.status != r.status;
      out = q.g;
    };
    const test::FiniteDifferenceCheck fd = test::check_jacobian(g, VectorXd::Zero(2), 1e-7 * dx, r.J);
    ASSERT_FALSE(crosses_kink) << c.name << ": the difference crosses a kink";
    EXPECT_LT(fd.worst, 1e-6) << c.name << fd;
    // Repulsion: the normal part of the force on j points away from i.
    EXPECT_LT(r.g.dot(c.normal == NormalLaw::paper ? n : Vec2((X + du).normalized())), 0.0) << c.name;
  }
}

// The same central differences (same tolerance and argument) for the exact-enforcement
// branch (docs/theory/contact.md, section 8): F = phi(|t.Y|) max(0, lambda + b C s) with a
// multiplier lambda and a boost b, in the full window and on its ramp, sticking and slipping
// (with the tangential multiplier of exact stick, and at the limit),
// and for a pair that has crossed (n.Y < 0); and for the penalty law's crossed branch, whose
// gate reads |t.Y| instead of |Y| (section 2).
TEST(ContactKernel, ExactAndCrossedBranchesMatchFiniteDifferences) {
  const double angle = -0.61;
  const Vec2 n(std::cos(angle), std::sin(angle)), t(-n.y(), n.x());
  ContactPair pair;
  pair.normal = n;
  pair.gap0 = dx;
  pair.stiffness = 2.5e4;
  const Vec2 X = dx * n + 0.1 * dx * t;
  struct ExactCase {
    const char* name;
    bool exact;
    double friction, multiplier;
    Vec2 du;      ///< (t, n) components in units of dx
    double slip;  ///< committed slip w_p in units of dx
    PairStatus status;
    double tangential_multiplier = 0.0;  ///< mu [N] (exact stick)
    double limit_sign = 0.0;             ///< +-1: the pair is at the limit +-f_c F (exact stick)
  };
  const std::vector<ExactCase> cases = {
      {"exact, window, stick", true, 0.5, 40.0, {0.0105, -0.001}, 0.01, PairStatus::stick},
      {"exact, window, slip", true, 0.2, 40.0, {0.3, -0.002}, 0.01, PairStatus::slip},
      // Exact stick: a stuck pair's multiplier mu adds to k_t (w - w_p) (F = 90 N, limit 45 N,
      // k_t (w - w_p) = 25 N); a pair at the limit (limit_sign) starts from +-f_c F, whose
      // derivative enters J, and slips on or sticks when pulled back.
      {"exact stick, multiplier", true, 0.5, 40.0, {0.0105, -0.001}, 0.01, PairStatus::stick, 10.0},
      {"exact stick, at the limit, pulled back", true, 0.5, 40.0, {0.0095, -0.001}, 0.01, PairStatus::stick, 0.0,
       1.0},
      {"exact stick, at the limit, slides on", true, 0.5, 40.0, {0.0105, -0.001}, 0.01, PairStatus::slip, 0.0, 1.0},
      {"exact stick, at the limit, ramp", true, 0.5, 40.0, {0.8305, -0.001}, 0.83, PairStatus::stick, 0.0, -1.0},
      {"exact, opened beyond what lambda carries", true, 0.2, 40.0, {0.3, 0.01}, 0.01, PairStatus::open},
      {"exact, window ramp, stick", true, 0.5, 40.0, {0.83, -0.001}, 0.8295, PairStatus::stick},
      {"exact, window ramp, slip", true, 0.1, 40.0, {0.84, -0.003}, 0.01, PairStatus::slip},
      {"exact, beyond the window", true, 0.5, 40.0, {1.2, -0.1}, 0.01, PairStatus::open},
      {"exact, crossed", true, 0.0, 40.0, {0.2, -1.4}, 0.0, PairStatus::slip},
      {"penalty, crossed, full", false, 0.0, 0.0, {0.3, -1.3}, 0.0, PairStatus::slip},
      {"penalty, crossed, ramp", false, 0.3, 0.0, {0.85, -1.5}, 0.01, PairStatus::slip},
  };
  for (const ExactCase& c : cases) {
    ContactLaw law;
    law.radius = 1.05 * dx;
    law.gate = 0.1;
    law.friction = c.friction;
    law.exact = c.exact;
    law.window = dx;
    const PairHistory history{c.slip * dx, c.multiplier, 0.0, 2.0, c.tangential_multiplier, c.limit_sign};
    const Vec2 du = dx * (c.du.x() * t + c.du.y() * n);
    const PairResult r = contact_pair(pair, X, du, history, law, true);
    ASSERT_EQ(r.status, c.status) << c.name;
    if (r.status == PairStatus::open) {
      EXPECT_EQ(r.g.norm(), 0.0) << c.name;
      continue;
    }
    bool crosses_kink = false;
    const auto g = [&](const VectorXd& d, VectorXd& out) {
      const PairResult q = contact_pair(pair, X, du + Vec2(d), history, law, false);
      crosses_kink = crosses_kink || q.status != r.status;
      out = q.g;
    };
    const test::FiniteDifferenceCheck fd = test::check_jacobian(g, VectorXd::Zero(2), 1e-7 * dx, r.J);
    ASSERT_FALSE(crosses_kink) << c.name << ": the difference crosses a kink";
    EXPECT_LT(fd.worst, 1e-6) << c.name << fd;
    // Whatever the state, the normal force on j points along +n: away from i's side, so a
    // crossed pair is pushed back to where it came from.
    EXPECT_LT(r.g.dot(n), 0.0) << c.name;
  }
}

// A pair that Newton throws past its partner must not become force-free (the defect of the
// distance gate: |Y| >= delta_c after crossing by a whole spacing released the pair, and the
// crossed state was an equilibrium). Penalty law: pushed back with C s, s = 1 - n.Y / a > 1.
TEST(ContactKernel, ACrossedPairIsPushedBackHarderNotReleased) {
  ContactPair pair;
  pair.normal = Vec2(1.0, 0.0);
  pair.gap0 = dx;
  pair.stiffness = 2.5e4;
  const Vec2 X(dx, 0.0);
  ContactLaw law;
  law.radius = dx;
  law.gate = 0.1;
  double previous = 0.0;
  for (const double yn : {0.5, 0.0, -0.5, -1.0, -2.0}) {  // n.Y in units of dx, head-on
    const Vec2 du = Vec2(yn * dx, 0.0) - X;
    const PairResult r = contact_pair(pair, X, du, PairHistory{}, law, false);
    const double expected = pair.stiffness * (1.0 - yn);  // full gate: |t.Y| = 0
    EXPECT_NEAR(r.normal_force, expected, 1e-12 * expected) << "n.Y = " << yn << " dx";
    EXPECT_GT(r.normal_force, previous) << "n.Y = " << yn << " dx";
    previous = r.normal_force;
  }
}

// The assembled tangent of a plate with a vertical crack closed by a compression of the
// faces and sheared by random tangential motion: contact and friction blocks included.
// Same tolerance argument as derivative.Tangent (1e-6 of max |K|).
TEST(ContactTangent, AssembledTangentMatchesFiniteDifferences) {
  // Friction coefficients chosen so that both stick and slip occur for this seed.
  // The exact variant takes one multiplier update at x first, so that lambda > 0 enters, and
  // with it exact stick's state: stuck pairs carry a tangential multiplier, sliding ones are
  // at the limit (f_c = 0.1 keeps both states after the update).
  struct Variant {
    const char *normal, *friction;
    bool exact;
  };
  for (const auto& [normal, friction, exact] :
       {Variant{"paper", "0.2", false}, Variant{"pair", "0.05", false}, Variant{"paper", "0.1", true}}) {
    test::PlateSpec spec;
    spec.nx = 12;
    spec.ny = 8;
    spec.dx = dx;
    spec.kinematics = "finite";
    spec.boundary = "  - {body: plate, edge: left, ux: 0, uy: 0}\n";
    spec.cracks = "  - {from: [0.0061, -0.001], to: [0.0061, 0.009]}\n";
    std::string yaml = test::plate_yaml(spec);
    yaml += std::string("contact:\n  friction: ") + friction + "\n  radius_factor: 1.2\n  normal: " + normal +
            "\n";
    if (exact) yaml += "  enforcement: exact\n";
    const Scene scene = test::scene_from_yaml(yaml);
    const Model model = discretise(scene);
    QuasiStaticProblem problem(model, problem_options(scene));
    problem.set_load_factor(1.0);
    ASSERT_GT(problem.contact()->size(), 0);

    // Compress across the crack (x strain -8 %) plus random motion of 2 % dx.
    std::mt19937 gen(11);
    std::uniform_real_distribution<double> d(-1.0, 1.0);
    const Index n = problem.n_unknowns();
    VectorXd x(n);
    for (Index p = 0; p < model.particles.size(); ++p)
      for (int c = 0; c < 2; ++c)
        if (const Index k = model.constraints.free_index[2 * p + c]; k >= 0)
          x[k] = (c == 0 ? -0.08 * model.particles.position[p].x() : 0.0) + 0.02 * dx * d(gen);

    if (exact) {
      ASSERT_EQ(problem.update_multipliers(x).status, ConstraintUpdate::Status::updated);
      double lambda_max = 0.0;
      for (Index k = 0; k < problem.contact()->size(); ++k)
        lambda_max = std::max(lambda_max, problem.contact()->multiplier(k));
      ASSERT_GT(lambda_max, 0.0);
    }
    SparseMatrix K = problem.make_tangent();
    VectorXd r;
    problem.evaluate(x, r, &K);
    const ContactCounts counts = problem.contact()->counts();
    EXPECT_GT(counts.stick, 0) << normal;
    EXPECT_GT(counts.slip, 0) << normal;
    EXPECT_FALSE(problem.traits().tangent_symmetric) << normal << ": slipping pairs make it unsymmetric";
    const test::FiniteDifferenceCheck fd = test::check_tangent(problem, x, 1e-7 * dx);
    EXPECT_LT(fd.worst, 1e-6) << normal << fd;
  }
}

}  // namespace
}  // namespace peristat

namespace peristat {
namespace {

// Large sliding (docs/theory/contact.md, section 10): two blocks side by side whose interface
// has slid by 3.6 spacings, beyond the reference candidates (a horizon, 3 dx), with friction
// and exact enforcement. commit() searches the faces again and the pattern grows; the
// tangent assembled on the new pattern, with new partners in contact, matches central
// differences (same tolerance as above: 1e-6 of max |K|).
TEST(ContactTangent, ConsistentAfterASearchChangesThePartners) {
  const std::string yaml =
      "name: sliding_blocks\n"
      "materials:\n  mat: {E: 1.0e9, nu: 0.3, thickness: 1.0e-3, kinematics: finite}\n"
      "discretization: {spacing: 1.0e-3}\n"
      "bodies:\n"
      "  left: {material: mat, rectangle: {min: [0, 0], max: [0.006, 0.012]}}\n"
      "  right: {material: mat, rectangle: {min: [0.006, 0], max: [0.012, 0.012]}}\n"
      "boundary:\n"
      "  - {body: left, edge: left, ux: 0, uy: 0}\n"
      "  - {body: right, edge: right, ux: 0, uy: 0}\n"
      "contact:\n  friction: 0.3\n  enforcement: exact\n  interfaces:\n    - {bodies: [left, right]}\n";
  const Scene scene = test::scene_from_yaml(yaml);
  const Model model = discretise(scene);
  QuasiStaticProblem problem(model, problem_options(scene));
  problem.set_load_factor(1.0);
  const Index before = problem.contact()->size();
  const std::uint64_t version = problem.traits().structure_version;

  // The left block slides up by 3.6 dx and both are pressed towards the interface by 2%
  // of a spacing, plus random motion of 0.5% dx.
  std::mt19937 gen(5);
  std::uniform_real_distribution<double> d(-1.0, 1.0);
  VectorXd x(problem.n_unknowns());
  for (Index p = 0; p < model.particles.size(); ++p) {
    const bool left = model.particles.body[p] == 0;
    for (int c = 0; c < 2; ++c)
      if (const Index k = model.constraints.free_index[2 * p + c]; k >= 0)
        x[k] = (c == 1 ? (left ? 3.6 * dx : 0.0) : (left ? 0.01 * dx : -0.01 * dx)) + 0.005 * dx * d(gen);
  }
  VectorXd r;
  problem.evaluate(x, r, nullptr);
  problem.commit(x);  // slid by more than half a spacing since the (reference) search: search again
  EXPECT_NE(problem.traits().structure_version, version);
  ASSERT_GT(problem.contact()->size(), before);
  ASSERT_EQ(problem.update_multipliers(x).status, ConstraintUpdate::Status::updated);

  SparseMatrix K = problem.make_tangent();
  problem.evaluate(x, r, &K);
  const ContactCounts counts = problem.contact()->counts();
  // Some of the pairs in contact are ones the search found.
  int new_active = 0;
  for (Index k = before; k < problem.contact()->size(); ++k)
    new_active += problem.contact()->result(k).status != PairStatus::open;
  std::printf("after the search: %ld candidates (%ld before), %ld stick, %ld slip, %d of the new ones active\n",
              long(problem.contact()->size()), long(before), long(counts.stick), long(counts.slip), new_active);
  EXPECT_GT(new_active, 0);
  const test::FiniteDifferenceCheck fd = test::check_tangent(problem, x, 1e-7 * dx);
  EXPECT_LT(fd.worst, 1e-6) << fd;
}

}  // namespace
}  // namespace peristat
