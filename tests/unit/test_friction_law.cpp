// The paper's velocity-sign friction (eq 13), kept as an ADR option: the kernel's sign
// convention, and the scene rule that Newton cannot use it.
#include <gtest/gtest.h>

#include "contact/contact.hpp"
#include "core/error.hpp"
#include "support/scenes.hpp"

namespace peristat {
namespace {

TEST(VelocitySignFriction, OpposesTheRelativeVelocityWithFcFn) {
  const double dx = 1e-3;
  const Vec2 n(0.0, 1.0), t(-1.0, 0.0);
  ContactPair pair;
  pair.normal = n;
  pair.gap0 = dx;
  pair.stiffness = 2.5e4;
  const Vec2 X = dx * n;
  ContactLaw law;
  law.radius = dx;
  law.gate = 0.1;
  law.friction = 0.5;
  law.velocity_sign = true;
  const Vec2 du = -0.2 * dx * n + 0.3 * dx * t;  // closed by 0.2 dx: in full contact
  for (double v : {1e-6, -1e-6, 0.0}) {
    const PairResult r = contact_pair(pair, X, du, PairHistory{0.0, 0.0, v}, law, false);
    ASSERT_GT(r.normal_force, 0.0);
    // tau > 0 puts -tau t on j: against j's velocity t . (v_j - v_i) = v. Exact: one product.
    const double expected = v > 0 ? law.friction * r.normal_force : (v < 0 ? -law.friction * r.normal_force : 0.0);
    EXPECT_EQ(r.tangential, expected) << "v = " << v;
    EXPECT_EQ(r.status, v == 0.0 ? PairStatus::stick : PairStatus::slip);
  }
  // Unlike the return map, the tangential displacement does not enter: the same velocity
  // sign gives the same force after a further tangential offset.
  const PairResult a = contact_pair(pair, X, du, PairHistory{0.0, 0.0, 1.0}, law, false);
  const PairResult b = contact_pair(pair, X, du + 0.1 * dx * t, PairHistory{0.0, 0.0, 1.0}, law, false);
  EXPECT_EQ(a.tangential, b.tangential);
}

TEST(VelocitySignFriction, NewtonRejectsIt) {
  const std::string base = R"(name: t
materials: {m: {E: 1.0e9, nu: 0.3, thickness: 1.0e-3}}
discretization: {spacing: 1.0e-3}
bodies: {a: {material: m, rectangle: {min: [0, 0], max: [0.01, 0.01]}}}
cracks: [{from: [0.002, 0.005], to: [0.008, 0.005]}]
contact:
  friction: 0.3
  friction_law: velocity_sign
)";
  try {
    test::scene_from_yaml(base);
    FAIL() << "a Newton scene with velocity_sign friction was accepted";
  } catch (const InputError& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("test.yaml:8"), std::string::npos) << m;  // the friction_law line
    EXPECT_NE(m.find("solver.type: adr"), std::string::npos) << m;
  }
  EXPECT_NO_THROW(test::scene_from_yaml(base + "solver: {type: adr}\n"));
}

}  // namespace
}  // namespace peristat
