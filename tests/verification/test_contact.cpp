// Contact and Coulomb friction against solutions known without peridynamics (issue 3):
// two blocks pressed together, a Coulomb block sheared past its friction limit, path
// (in)dependence, and a pre-cracked plate whose faces must not pass through each other.
// Each test states its tolerance and why.
#include <cmath>
#include <cstdio>
#include <sstream>

#include <gtest/gtest.h>

#include "support/scenes.hpp"
#include "support/solve.hpp"

namespace peristat {
namespace {

// Two blocks of nx x ny particles, `lower` on [0, W] x [0, H] and `upper` on [0, W] x [H, 2H],
// touching along y = H. Lower: bottom edge uy = 0 (and ux = 0 when `clamp_x`). Upper: top
// edge uy = -press (and ux = shear when `clamp_x`). Without `clamp_x`, ux = 0 holds on the
// two bottom and the two top particles nearest mid-width (no rigid motion, free sides).
struct BlocksSpec {
  int nx = 30, ny = 20;
  double dx = 1e-3;
  double E = 1e9, nu = 0.3, thickness = 1e-3;
  double press = 0.0, shear = 0.0;
  bool clamp_x = false;
  bool contact = true;
  double friction = 0.0;
  int steps = 1;
  std::string enforcement = "penalty";
  std::string contact_extra;  ///< more lines of the contact section, each "  key: value\n"
};

std::string blocks_yaml(const BlocksSpec& s) {
  const double W = s.nx * s.dx, H = s.ny * s.dx, mid = 0.5 * W;
  std::ostringstream y;
  y.precision(17);
  y << "name: blocks\n"
    << "materials:\n  mat: {E: " << s.E << ", nu: " << s.nu << ", thickness: " << s.thickness
    << ", kinematics: small}\n"
    << "discretization: {spacing: " << s.dx << ", horizon_factor: 3}\n"
    << "bodies:\n"
    << "  lower: {material: mat, rectangle: {min: [0, 0], max: [" << W << ", " << H << "]}}\n"
    << "  upper: {material: mat, rectangle: {min: [0, " << H << "], max: [" << W << ", " << 2 * H << "]}}\n"
    << "boundary:\n";
  if (s.clamp_x) {
    y << "  - {body: lower, edge: bottom, ux: 0, uy: 0}\n"
      << "  - {body: upper, edge: top, ux: " << s.shear << ", uy: " << -s.press << "}\n";
  } else {
    y << "  - {body: lower, edge: bottom, uy: 0}\n"
      << "  - {body: lower, region: {min: [" << mid - s.dx << ", 0], max: [" << mid + s.dx << ", " << s.dx
      << "]}, ux: 0}\n"
      << "  - {body: upper, edge: top, uy: " << -s.press << "}\n"
      << "  - {body: upper, region: {min: [" << mid - s.dx << ", " << 2 * H - s.dx << "], max: ["
      << mid + s.dx << ", " << 2 * H << "]}, ux: 0}\n";
  }
  y << "contact:\n  enabled: " << (s.contact ? "true" : "false") << "\n  enforcement: " << s.enforcement
    << "\n  friction: " << s.friction << "\n"
    << s.contact_extra << "  interfaces:\n    - {bodies: [lower, upper]}\n"
    << "loading: {steps: " << s.steps << "}\n"
    << "solver:\n  linear: umfpack\n  newton: {rtol: 1.0e-12}\n";
  return y.str();
}

// Total contact force acting on the real particles of body `b` (index in scene order).
Vec2 contact_force_on(const test::Solved& s, int b) {
  VectorXd f;
  s.problem->contact()->contact_force(f);
  Vec2 total = Vec2::Zero();
  const Particles& p = s.model.particles;
  for (Index i = 0; i < p.size(); ++i)
    if (p.body[i] == b) total += Vec2(f[2 * i], f[2 * i + 1]);
  return total;
}

// Over the candidate pairs, using displacement u: the smallest current normal distance
// n.(Y) and the largest normal closure (a - n.Y) / a.
struct PairGeometry {
  double min_normal_distance = 1e300, max_closure = -1e300;
};
PairGeometry pair_geometry(const ContactSystem& contact, const Model& model, const VectorXd& u) {
  PairGeometry g;
  for (const ContactPair& pr : contact.pairs()) {
    const Vec2 X = model.particles.position[pr.j] - model.particles.position[pr.i];
    const Vec2 Y = X + Vec2(u[2 * pr.j] - u[2 * pr.i], u[2 * pr.j + 1] - u[2 * pr.i + 1]);
    const double dn = pr.normal.dot(Y);
    g.min_normal_distance = std::min(g.min_normal_distance, dn);
    g.max_closure = std::max(g.max_closure, (pr.gap0 - dn) / pr.gap0);
  }
  return g;
}

double relative_difference(const VectorXd& a, const VectorXd& b) {
  return (a - b).norm() / b.norm();
}

// Two blocks pressed together, frictionless, free sides. Away from the sides each block is
// in uniaxial stress, sigma_yy = E eps. In the middle of the interface the contact pressure
// is that stress, and the interface closes by s a, a = dx, with s = 9 p / E_c (paper law,
// delta = 3 dx, one active pair per column: the pair force C s with C = E_c dx t / 9 over the
// column width dx t gives p = E_c s / 9; E_c of eq 17; docs/theory/contact.md). The total
// contact force equals the reaction at the loaded edge.
TEST(PressedBlocks, ForceAndClosureMatchTheElasticSolution) {
  BlocksSpec spec;
  spec.nx = 60;
  spec.press = 1.2 * spec.dx;  // more than one spacing: without contact the blocks would overlap
  auto s = test::solve_scene(blocks_yaml(spec));
  ASSERT_TRUE(s->run.completed) << s->run.message;
  const ContactSystem& c = *s->problem->contact();
  const Particles& P = s->model.particles;
  const double W = spec.nx * spec.dx, H = spec.ny * spec.dx, t = spec.thickness, dx = spec.dx;

  // Interior of each block: two horizons from the free sides, one from the loaded edge and
  // the interface. Strain from an affine fit of uy, stress from the force state.
  const double xm = 6 * dx, ym = 3 * dx;
  auto interior = [&](double y0) {
    const Eigen::Vector3d fit = test::fit_affine(*s, 1, Vec2(xm, y0 + ym), Vec2(W - xm, y0 + H - ym));
    Mat2 S = Mat2::Zero();
    int n = 0;
    for (Index i = 0; i < P.size(); ++i) {
      const Vec2& X = P.position[i];
      if (!P.fictitious[i] && X.x() > xm && X.x() < W - xm && X.y() > y0 + ym && X.y() < y0 + H - ym) {
        S += s->problem->stress(i);
        ++n;
      }
    }
    return std::pair{fit[2], Mat2(S / n)};
  };
  const auto [eps_low, S_low] = interior(0.0);
  const auto [eps_up, S_up] = interior(H);
  const Vec2 F_up = contact_force_on(*s, 1), F_low = contact_force_on(*s, 0);
  const double E_c = spec.E / (2 * (1 - spec.nu * spec.nu));

  // Reaction at the upper block's loaded edge: the internal force on its prescribed layers.
  double reaction = 0.0;
  const VectorXd& f_int = s->problem->internal_force();
  for (Index i = 0; i < P.size(); ++i)
    if (P.fictitious[i] && P.body[i] == 1) reaction += f_int[2 * i + 1];

  // Middle of the interface (the 4 central columns): closure = the jump of uy between the
  // rows either side; p_mid = contact force on the upper row / its width.
  VectorXd f;
  c.contact_force(f);
  double u_below = 0, u_above = 0, f_above = 0;
  int n_below = 0, n_above = 0;
  for (Index i = 0; i < P.size(); ++i) {
    const Vec2& X = P.position[i];
    if (P.fictitious[i] || std::abs(X.x() - 0.5 * W) > 2 * dx) continue;
    if (std::abs(X.y() - (H - 0.5 * dx)) < 1e-9) u_below += s->u[2 * i + 1], ++n_below;
    if (std::abs(X.y() - (H + 0.5 * dx)) < 1e-9) {
      u_above += s->u[2 * i + 1], ++n_above;
      f_above += f[2 * i + 1];
    }
  }
  const double closure = (u_below / n_below - u_above / n_above) / dx;
  const double p_mid = f_above / (n_above * dx * t);
  const double sigma = -S_up(1, 1);
  const PairGeometry g = pair_geometry(c, s->model, s->u);
  std::printf(
      "pressed blocks %d x %d: eps = %.6e (lower) %.6e (upper); interior sigma_yy / (E eps) = %.5f, "
      "|sigma_xx / sigma_yy| = %.4f; p_mid / sigma_yy = %.5f; closure %.5f dx = %.7f x 9 p_mid / E_c; "
      "F / (sigma_yy W t) = %.5f; F / reaction = %.10f; min normal distance %.4f dx; %ld active of %ld\n",
      spec.nx, spec.ny, eps_low, eps_up, sigma / (spec.E * -eps_up), std::abs(S_up(0, 0) / S_up(1, 1)),
      p_mid / sigma, closure, closure / (9 * p_mid / E_c), F_up.y() / (sigma * W * t),
      F_up.y() / std::abs(reaction), g.min_normal_distance / dx, long(c.counts().active()),
      long(c.counts().candidates));

  // Action and reaction (round-off): the assembled contact forces on the two bodies
  // balance, and the upper block's contact force equals the reaction at its loaded edge.
  EXPECT_LT((F_up + F_low).norm(), 1e-10 * F_up.norm());
  EXPECT_NEAR(F_up.y() / std::abs(reaction), 1.0, 1e-8);
  // Frictionless and symmetric: no shear through the interface.
  EXPECT_LT(std::abs(F_up.x()), 1e-8 * F_up.y());
  // One active pair per column, the pairs straight across.
  EXPECT_EQ(c.counts().active(), spec.nx);
  // Both blocks carry the same interior strain and stress.
  EXPECT_NEAR(eps_low / eps_up, 1.0, 1e-3);
  EXPECT_NEAR(S_low(1, 1) / S_up(1, 1), 1.0, 1e-3);
  // Uniaxial stress in the interior: sigma_yy = E eps within 1% (the lattice's measured E,
  // verification.Uniaxial*), sigma_xx below 5% of sigma_yy (the stiffer peridynamic surface
  // strips along the free sides and the fixed-uy edges make the field not quite uniaxial).
  EXPECT_NEAR(sigma / (spec.E * -eps_up), 1.0, 0.01);
  EXPECT_LT(std::abs(S_up(0, 0) / S_up(1, 1)), 0.05);
  // The contact pressure in the middle equals the stress the blocks carry there, within 3%
  // (the same non-uniformity: the clamped loaded edges hold the Poisson expansion back, so
  // the continuum's field is not uniform either; measured 1.022 uncorrected, 1.025 with the
  // surface correction).
  EXPECT_NEAR(p_mid / sigma, 1.0, 0.03);
  // The closure follows the contact law. 1e-3: the rows are uniform to that level, and the
  // paper law's force depends on the normal approach only.
  EXPECT_NEAR(closure / (9 * p_mid / E_c), 1.0, 1e-3);
  // The whole interface carries the interior stress plus the stiffer surface strips along
  // the free sides (peridynamic surface effect): F / (sigma W t) between 1 and 1.04.
  EXPECT_GT(F_up.y() / (sigma * W * t), 1.0);
  EXPECT_LT(F_up.y() / (sigma * W * t), 1.04);
  // No interpenetration: every pair keeps a positive normal distance (here about 0.6 dx:
  // the paper law is soft, p = E_c s / 9, so s = 0.34 at a strain of 2%).
  EXPECT_GT(g.min_normal_distance / dx, 0.5);
}

TEST(PressedBlocks, WithoutContactTheBlocksOverlap) {
  BlocksSpec spec;
  spec.press = 1.2 * spec.dx;
  auto with = test::solve_scene(blocks_yaml(spec));
  spec.contact = false;
  auto without = test::solve_scene(blocks_yaml(spec));
  ASSERT_TRUE(with->run.completed && without->run.completed);
  // The same pairs, measured on the run without contact: the upper block moves down
  // rigidly by 1.2 dx, so every pair straight across ends at -0.2 dx (round-off tolerance).
  const PairGeometry g = pair_geometry(*with->problem->contact(), with->model, without->u);
  std::printf("without contact: min normal distance %.6f dx\n", g.min_normal_distance / spec.dx);
  EXPECT_NEAR(g.min_normal_distance / spec.dx, -0.2, 1e-9);
}

// The pressed blocks with exact enforcement at three contact stiffnesses spanning 1e4: the
// interface closes to within contact.closure_tolerance (1e-3 of the pair distance) whatever
// the stiffness, so the two blocks carry the strain of one block of height 2H, and the three
// answers agree to the tolerance's effect on the field.
TEST(PressedBlocks, ExactEnforcementClosesTheInterfaceAtAnyStiffness) {
  std::vector<VectorXd> answers;
  for (const double stiffness : {4e7, 4e9, 4e11}) {  // 0.04, 4 and 400 x the eq 17 modulus (0.55 GPa)
    BlocksSpec spec;
    spec.nx = 40;
    spec.press = 1.2 * spec.dx;
    spec.enforcement = "exact";
    std::string yaml = blocks_yaml(spec);
    yaml.replace(yaml.find("  friction:"), 0, "  stiffness: " + std::to_string(stiffness) + "\n");
    auto s = test::solve_scene(yaml);
    ASSERT_TRUE(s->run.completed) << s->run.message;
    const ContactSystem& c = *s->problem->contact();
    const double dx = spec.dx, W = spec.nx * dx, H = spec.ny * dx;
    // Largest closure over the pairs straight across (computed here from u, independently of
    // the program's own check), and the interior strain of each block.
    const PairGeometry g = pair_geometry(c, s->model, s->u);
    const double xm = 6 * dx, ym = 3 * dx;
    const double eps_low = test::fit_affine(*s, 1, Vec2(xm, ym), Vec2(W - xm, H - ym))[2];
    const double eps_up = test::fit_affine(*s, 1, Vec2(xm, H + ym), Vec2(W - xm, 2 * H - ym))[2];
    int updates = 0;
    for (const StepReport& r : s->steps) updates += r.multiplier_updates;
    std::printf(
        "exact pressed blocks, E_c = %.0e Pa: largest closure %.3e (tolerance 1e-3), eps %.6e / %.6e, "
        "%d multiplier updates, %ld Newton iterations\n",
        stiffness, g.max_closure, eps_low, eps_up, updates, s->iterations());
    // Closure within the tolerance (plus the round-off of the update's own measurement).
    EXPECT_LT(g.max_closure, 1e-3 * (1 + 1e-9)) << stiffness;
    EXPECT_GT(g.min_normal_distance / dx, 0.99) << stiffness;
    EXPECT_NEAR(eps_low / eps_up, 1.0, 1e-3) << stiffness;
    answers.push_back(s->u);
  }
  // A closure of at most 1e-3 dx at each of the 20 + 20 rows' interface changes the blocks'
  // 1.2 dx shortening by at most 1e-3 / 1.2 ~ 1e-3 relative: the answers agree to 2e-3.
  for (std::size_t k = 1; k < answers.size(); ++k)
    EXPECT_LT(relative_difference(answers[k], answers[0]), 2e-3) << k;
}

// The Coulomb block: the lower block's bottom is clamped, the upper block's top is pressed
// down by d_n and moved sideways by d_t. Below the friction limit the interface sticks;
// past it every active pair slips and the interface carries exactly f_c N.
struct CoulombOutcome {
  double N, T;
  ContactCounts counts;
  int newton_iterations;
};

CoulombOutcome coulomb(double shear_over_dx, double friction, int steps,
                       const std::string& enforcement = "penalty", const std::string& contact_extra = "") {
  BlocksSpec spec;
  spec.enforcement = enforcement;
  spec.contact_extra = contact_extra;
  spec.clamp_x = true;
  spec.press = 0.5 * spec.dx;
  spec.shear = shear_over_dx * spec.dx;
  spec.friction = friction;
  spec.steps = steps;
  auto s = test::solve_scene(blocks_yaml(spec));
  EXPECT_TRUE(s->run.completed) << s->run.message;
  const Vec2 F = contact_force_on(*s, 1);
  int its = 0;
  for (const StepReport& r : s->steps) its += r.newton_iterations;
  CoulombOutcome o{F.y(), -F.x(), s->problem->contact()->counts(), its};
  std::printf(
      "coulomb block (%s) d_t = %.3g dx, f_c = %.2f, %d steps: N = %.6e N, T = %.6e N, T / (f_c N) = %.9f, "
      "open %ld stick %ld slip %ld, %d Newton iterations\n",
      enforcement.c_str(), shear_over_dx, friction, steps, o.N, o.T, o.T / (friction * o.N), long(o.counts.open),
      long(o.counts.stick), long(o.counts.slip), its);
  return o;
}

void coulomb_block_laws(const std::string& enforcement) {
  const double fc = 0.1;
  // Exact enforcement stops its multiplier updates once every violation is within the closure
  // tolerance, so its answer carries the tolerance (up to 1e-3 of a pair's distance by
  // default); the linearity below is asked of the law, so the tolerance is made negligible.
  const std::string tight = enforcement == "exact" ? "  closure_tolerance: 1.0e-9\n" : "";
  const CoulombOutcome stick = coulomb(0.002, fc, 1, enforcement, tight);
  EXPECT_GT(stick.N, 0.0);
  EXPECT_GT(stick.T, 0.0);  // friction resists the upper block's motion (+x)
  EXPECT_LT(stick.T, fc * stick.N);
  EXPECT_EQ(stick.counts.slip, 0);
  EXPECT_GT(stick.counts.stick, 0);
  // Sticking is elastic: twice the shear displacement gives twice the shear force (1e-6:
  // the normal force, which sets the contact state, does not change with d_t to first order).
  const CoulombOutcome stick2 = coulomb(0.004, fc, 1, enforcement, tight);
  EXPECT_EQ(stick2.counts.slip, 0);
  EXPECT_NEAR(stick2.T / stick.T, 2.0, 1e-6);

  const CoulombOutcome slip = coulomb(0.3, fc, 1, enforcement);
  EXPECT_EQ(slip.counts.stick, 0);
  EXPECT_GT(slip.counts.slip, 0);
  // In slip every pair carries f_c times its normal force, so the totals do too; 1e-9
  // relative is the Newton tolerance (1e-12) with margin.
  EXPECT_NEAR(slip.T / (fc * slip.N), 1.0, 1e-9);
}

TEST(CoulombBlock, SticksBelowTheLimitAndSlipsAtFcN) { coulomb_block_laws("penalty"); }

// The same laws with exact enforcement: the normal force now comes from the multipliers,
// and stick and slip still come out of the return map (docs/theory/contact.md, section 8).
TEST(CoulombBlock, ExactEnforcementSticksBelowTheLimitAndSlipsAtFcN) { coulomb_block_laws("exact"); }

// Exact stick (docs/theory/contact.md, section 8): under exact enforcement a stuck pair's
// tangential force is a multiplier too, so stuck faces do not creep. The blocks pressed by
// 0.5 dx and sheared by d_t = 0.02 dx with f_c = 0.5 stick everywhere. With the penalty stick
// (`contact.stick: penalty`) the faces creep by tau / k_t: measured 2.0e-3 of the pairs' normal
// distance a, twice the closure tolerance. With exact stick every stuck pair's slip from its
// anchor (zero: one step from rest) is within the tolerance, 1e-3 a (plus round-off); measured
// 1.5e-5 a. The shear force then comes close to that of one block of the same size, whose
// material is whole where the interface is (its horizontal grip reaction): measured 1.058 of it
// with exact stick, 0.966 with the penalty's; within 8% asked (the facing pairs are rigid links
// one spacing long, where the block has a spacing of material, "What exact leaves").
struct StickOutcome {
  double T = 0.0;          ///< horizontal force on the upper grip's layers [N]
  double worst_slip = 0.0;  ///< largest |t.(u_j - u_i)| / a over the stuck pairs
  long stick = 0, slip = 0;
};

StickOutcome sheared_blocks(const std::string& yaml) {
  auto s = test::solve_scene(yaml);
  EXPECT_TRUE(s->run.completed) << s->run.message;
  StickOutcome o;
  const Particles& P = s->model.particles;
  const VectorXd& f_int = s->problem->internal_force();
  const int top_body = static_cast<int>(s->model.bodies.size()) - 1;
  for (Index i = 0; i < P.size(); ++i)
    if (P.fictitious[i] && P.body[i] == top_body && P.position[i].y() > 0.02) o.T += f_int[2 * i];
  if (const ContactSystem* c = s->problem->contact()) {
    for (Index k = 0; k < c->size(); ++k) {
      const ContactPair& pr = c->pairs()[k];
      if (c->result(k).status != PairStatus::stick) continue;
      const Vec2 du(s->u[2 * pr.j] - s->u[2 * pr.i], s->u[2 * pr.j + 1] - s->u[2 * pr.i + 1]);
      o.worst_slip = std::max(o.worst_slip, std::abs(pr.tangent().dot(du)) / pr.gap0);
    }
    o.stick = c->counts().stick;
    o.slip = c->counts().slip;
  }
  return o;
}

/// The Coulomb block pressed by 0.5 dx and sheared by `shear_over_dx` spacings, f_c = 0.5
/// (stuck), exact enforcement.
BlocksSpec stuck_blocks(double shear_over_dx) {
  BlocksSpec spec;
  spec.clamp_x = true;
  spec.press = 0.5 * spec.dx;
  spec.shear = shear_over_dx * spec.dx;
  spec.friction = 0.5;
  spec.enforcement = "exact";
  return spec;
}

// When the multiplier updates run out, the message says what the worst pair violates, so a
// user knows which of contact.closure_tolerance's three readings failed. One update and a
// tolerance of 1e-9: pressed frictionless blocks keep a closure; the stuck blocks (pressed
// and sheared, f_c = 0.5, a soft stick) keep a slip from their anchors.
TEST(CoulombBlock, ExhaustedMultiplierUpdatesNameTheViolation) {
  auto message = [](BlocksSpec spec, const std::string& extra) {
    std::string y = blocks_yaml(spec);
    y.replace(y.find("  friction:"), 0, "  closure_tolerance: 1.0e-9\n  max_multiplier_updates: 1\n" + extra);
    y.replace(y.find("steps: 1}"), 9, "steps: 1, max_cutbacks: 0}");
    auto s = test::solve_scene(y);
    EXPECT_FALSE(s->run.completed);
    std::printf("%s\n", s->run.message.c_str());
    return s->run.message;
  };
  BlocksSpec pressed = stuck_blocks(0.0);
  pressed.friction = 0.0;
  // A soft stick (tangential_factor 0.01: the trial slip is 100 times the default's) and a
  // stiff normal augmentation (stiffness 5e9 Pa, about 9 x the eq 17 modulus: started from
  // 1 x, the closure after one update was about 0.04, above the slip) make the slip the
  // larger violation of the sheared blocks.
  const std::string closure = message(pressed, "");
  const std::string slip = message(stuck_blocks(0.02), "  tangential_factor: 0.01\n  stiffness: 5.0e9\n");
  EXPECT_NE(closure.find("exact contact: closure"), std::string::npos);
  EXPECT_NE(slip.find("exact contact: stuck slip"), std::string::npos);
}

TEST(CoulombBlock, ExactStickHoldsWhereThePenaltyCreeps) {
  const BlocksSpec spec = stuck_blocks(0.02);
  const std::string exact = blocks_yaml(spec);
  std::string penalty = exact;
  penalty.replace(penalty.find("  friction:"), 0, "  stick: penalty\n");
  const double W = spec.nx * spec.dx, H = 2 * spec.ny * spec.dx;
  std::ostringstream one;
  one.precision(17);
  one << "name: one_block\nmaterials:\n  mat: {E: " << spec.E << ", nu: " << spec.nu
      << ", thickness: " << spec.thickness << ", kinematics: small}\n"
      << "discretization: {spacing: " << spec.dx << ", horizon_factor: 3}\n"
      << "bodies:\n  block: {material: mat, rectangle: {min: [0, 0], max: [" << W << ", " << H << "]}}\n"
      << "boundary:\n  - {body: block, edge: bottom, ux: 0, uy: 0}\n"
      << "  - {body: block, edge: top, ux: " << spec.shear << ", uy: " << -spec.press << "}\n"
      << "loading: {steps: 1}\nsolver:\n  linear: umfpack\n  newton: {rtol: 1.0e-12}\n";
  const StickOutcome e = sheared_blocks(exact), p = sheared_blocks(penalty), m = sheared_blocks(one.str());
  std::printf("sheared blocks, f_c = 0.5: T exact stick %.6e N (%ld stick, %ld slip, worst slip %.3e a), "
              "penalty stick %.6e N (%ld stick, %ld slip, worst slip %.3e a), one block %.6e N; exact / one %.4f, penalty / one %.4f\n",
              e.T, e.stick, e.slip, e.worst_slip, p.T, p.stick, p.slip, p.worst_slip, m.T, e.T / m.T, p.T / m.T);
  EXPECT_GT(e.stick, 0);
  EXPECT_EQ(e.slip, 0);
  EXPECT_GT(p.worst_slip, 1e-3);  // the creep exact stick removes is there under the penalty
  EXPECT_LE(e.worst_slip, 1e-3 * (1 + 1e-9));
  EXPECT_NEAR(e.T / m.T, 1.0, 0.08);
}

// Exact stick keeps Newton quadratic, and ADR, which runs the same multiplier updates between
// its solves, reaches the same state. The sheared blocks with finite kinematics (press 0.5 dx,
// shear 0.05 dx, f_c = 0.5: stuck, with updates of the stick multipliers). The observed order
// p = log(r_{k+1} / r_k) / log(r_k / r_{k-1}) within each solve, over the iterates below 1e-2
// whose successor is above round-off, is at least 1.5: each solve takes two iterations from
// a residual of about 0.5 N to round-off (0.50 -> 9.4e-5 -> 3.1e-11 and 0.82 -> 2.0e-5 ->
// 7.0e-13, measured p = 1.74 and 1.61), so the three-point estimate includes a first step
// outside the asymptotic range and reads below 2; an inexact tangent, such as one missing the
// stick multiplier's terms, converges linearly, p near 1. ADR to rtol 1e-8 against Newton to
// 1e-12: within 1e-6 relative L2, the bound of Adr.AgreesWithNewtonWithExactContact.
TEST(CoulombBlock, ExactStickNewtonIsQuadraticAndAdrAgrees) {
  std::string yaml = blocks_yaml(stuck_blocks(0.05));
  yaml.replace(yaml.find("kinematics: small"), 17, "kinematics: finite");
  yaml.replace(yaml.find("rtol: 1.0e-12"), 13, "rtol: 1.0e-14, max_iterations: 30");
  auto newton = test::solve_scene(yaml);
  ASSERT_TRUE(newton->run.completed) << newton->run.message;
  const ContactCounts counts = newton->problem->contact()->counts();
  EXPECT_GT(counts.stick, 0);
  const std::vector<double>& r = newton->steps.at(0).residuals;
  int measured = 0;
  for (std::size_t k = 1; k + 1 < r.size(); ++k) {
    const bool same_solve = r[k] < r[k - 1] && r[k + 1] < r[k];  // a multiplier update restarts the sequence
    std::printf("residual %.3e", r[k]);
    if (same_solve && r[k + 1] > 1e-13 && r[k] < 1e-2) {
      const double p = std::log(r[k + 1] / r[k]) / std::log(r[k] / r[k - 1]);
      std::printf("  order %.2f", p);
      EXPECT_GE(p, 1.5) << "at residual " << k;
      ++measured;
    }
    std::printf("\n");
  }
  EXPECT_GE(measured, 1) << "no iterate in the asymptotic range";
  std::string adr_yaml = yaml;
  adr_yaml.replace(adr_yaml.find("  linear: umfpack"), std::string::npos, "  type: adr\n  adr: {rtol: 1.0e-8}\n");
  auto adr = test::solve_scene(adr_yaml);
  ASSERT_TRUE(adr->run.completed) << adr->run.message;
  const double d = relative_difference(adr->u, newton->u);
  std::printf("exact stick, finite kinematics: %ld stick, %ld slip; ADR %ld iterations against Newton %ld: "
              "relative L2 difference %.3e\n",
              long(counts.stick), long(counts.slip), adr->iterations(), newton->iterations(), d);
  EXPECT_LT(d, 1e-6);
}

// Frictionless contact is elastic, hence independent of the load-step count; so is a
// frictional run that sticks throughout, and one that slips uniformly under proportional
// loading (every pair ends at tau = f_c F whatever the steps). Tolerance 1e-8: Newton
// converges to 1e-12.
TEST(ContactPath, ProportionalLoadingIsIndependentOfTheStepCount) {
  for (const auto& [friction, shear] : {std::pair{0.0, 0.3}, std::pair{0.1, 0.002}, std::pair{0.1, 0.3}}) {
    BlocksSpec spec;
    spec.clamp_x = true;
    spec.press = 0.5 * spec.dx;
    spec.shear = shear * spec.dx;
    spec.friction = friction;
    spec.steps = 1;
    auto one = test::solve_scene(blocks_yaml(spec));
    spec.steps = 4;
    auto four = test::solve_scene(blocks_yaml(spec));
    ASSERT_TRUE(one->run.completed && four->run.completed);
    const double d = relative_difference(one->u, four->u);
    std::printf("f_c = %.1f, d_t = %.3g dx: |u(1 step) - u(4 steps)| / |u| = %.3e\n", friction, shear, d);
    EXPECT_LT(d, 1e-8);
  }
}

// Loading past the friction limit and back is where Coulomb friction remembers its path.
// Load factor 0 -> 1 -> 0.5 against 0 -> 0.5 directly, on the Coulomb block (d_n = 0.5 dx,
// d_t = 0.3 dx). Frictionless: the same answer (1e-8, Newton converges to 1e-12). With
// f_c = 0.1 the direct path slips everywhere (T = f_c N) while on the way back the slipped
// interface mostly sticks and keeps its slip, so the fields differ by far more than the
// solver tolerance (asserted > 1e-3 relative) and the shear force is below f_c N.
struct PathEnd {
  VectorXd u;
  ContactCounts counts;
  double T_over_fcN;
};

PathEnd follow(double friction, const std::vector<double>& path) {
  BlocksSpec spec;
  spec.clamp_x = true;
  spec.press = 0.5 * spec.dx;
  spec.shear = 0.3 * spec.dx;  // at f_c = 0.1 the interface sticks up to about 0.18 dx
  spec.friction = friction;
  const Scene scene = test::scene_from_yaml(blocks_yaml(spec));
  const Model model = discretise(scene);
  QuasiStaticProblem problem(model, problem_options(scene));
  auto linear = make_linear_solver(scene.solver.linear);
  NewtonSolver newton(problem, *linear, scene.solver.newton);
  VectorXd x = VectorXd::Zero(problem.n_unknowns());
  problem.set_load_factor(0.0);
  for (double lambda : path) {
    if (!newton.prepared()) newton.prepare(x);
    problem.set_load_factor(lambda);
    const SolveReport r = newton.solve(x);
    EXPECT_TRUE(r.converged) << "load factor " << lambda << ": " << r.reason;
    std::printf("  f_c = %.1f, load factor %.2f: %d Newton iterations, stick %ld, slip %ld\n", friction,
                lambda, r.iterations, long(problem.contact()->counts().stick),
                long(problem.contact()->counts().slip));
    problem.commit(x);
  }
  PathEnd end;
  problem.expand(x, end.u);
  end.counts = problem.contact()->counts();
  VectorXd f;
  problem.contact()->contact_force(f);
  Vec2 F = Vec2::Zero();
  for (Index i = 0; i < model.particles.size(); ++i)
    if (model.particles.body[i] == 1) F += Vec2(f[2 * i], f[2 * i + 1]);
  end.T_over_fcN = friction > 0 ? -F.x() / (friction * F.y()) : 0.0;
  return end;
}

TEST(ContactPath, LoadingAndUnloadingRemembersTheSlip) {
  const PathEnd smooth0 = follow(0.0, {0.5}), back0 = follow(0.0, {1.0, 0.5});
  const double d0 = relative_difference(back0.u, smooth0.u);
  const PathEnd direct = follow(0.1, {0.5}), back = follow(0.1, {1.0, 0.5});
  const double d = relative_difference(back.u, direct.u);
  std::printf(
      "frictionless: |u(0->1->0.5) - u(0->0.5)| / |u| = %.3e\n"
      "f_c = 0.1: |u(0->1->0.5) - u(0->0.5)| / |u| = %.3e; direct: stick %ld slip %ld T/(f_c N) %.6f; "
      "back: stick %ld slip %ld T/(f_c N) %.6f\n",
      d0, d, long(direct.counts.stick), long(direct.counts.slip), direct.T_over_fcN, long(back.counts.stick),
      long(back.counts.slip), back.T_over_fcN);
  EXPECT_LT(d0, 1e-8);
  EXPECT_GT(d, 1e-3);
  EXPECT_GT(direct.counts.slip, 0);
  EXPECT_NEAR(direct.T_over_fcN, 1.0, 1e-9);
  EXPECT_EQ(direct.counts.stick, 0);
  // Unloading: most pairs stick (the few that slip back sit at the free sides, where the
  // normal force is smallest), and the interface carries less than f_c N, still forward.
  EXPECT_GT(back.counts.stick, 3 * back.counts.slip);
  EXPECT_GT(back.T_over_fcN, 0.0);
  EXPECT_LT(back.T_over_fcN, 0.9);
}

// A pre-cracked plate in compression (case 4.3 at half its resolution, frictionless): with
// contact the crack faces close only by the penalty closure; without contact they run into
// each other. Both solutions are measured on the crack pairs of the contact run.
TEST(PrecrackedPlate, ContactKeepsTheFacesApart) {
  auto yaml = [](bool contact) {
    std::ostringstream y;
    y << "name: precracked\n"
      << "materials:\n  m: {E: 10.0e9, nu: 0.3, thickness: 0.01, kinematics: small}\n"
      << "discretization: {spacing: 0.02, horizon_factor: 3}\n"
      << "bodies:\n  plate: {material: m, rectangle: {min: [-0.5, -0.5], max: [0.5, 0.5]}}\n"
      << "cracks:\n  - {from: [-0.2, -0.2], to: [0.2, 0.2]}\n"
      << "boundary:\n  - {body: plate, edge: bottom, ux: 0, uy: 0}\n"
      << "  - {body: plate, edge: top, ux: 0, uy: -9.0e-3}\n"
      << "contact: {enabled: " << (contact ? "true" : "false") << ", friction: 0.0, cracks: true}\n"
      << "loading: {steps: 2}\n"
      << "solver: {linear: umfpack, newton: {rtol: 1.0e-11}}\n";
    return y.str();
  };
  auto with = test::solve_scene(yaml(true));
  auto without = test::solve_scene(yaml(false));
  ASSERT_TRUE(with->run.completed && without->run.completed);
  // The crack pairs of the contact run, measured on both solutions (same particles).
  const ContactSystem& c = *with->problem->contact();
  const PairGeometry gw = pair_geometry(c, with->model, with->u);
  const PairGeometry go = pair_geometry(c, with->model, without->u);
  std::printf(
      "pre-cracked plate: %ld pairs; with contact: max closure %.4f, min normal distance %.4f dx; "
      "without: max closure %.4f, min normal distance %.4f dx\n",
      long(c.size()), gw.max_closure, gw.min_normal_distance / 0.02, go.max_closure,
      go.min_normal_distance / 0.02);
  // With contact: no pair closes by more than 15% of its normal gap (the penalty closure
  // s = 9 p / E_c of the paper law at this load is about 0.1) and no pair comes closer than
  // half a spacing along the normal.
  EXPECT_LT(gw.max_closure, 0.15);
  EXPECT_GT(gw.min_normal_distance / 0.02, 0.5);
  // Without contact the faces run into each other: the largest closure is at least three
  // times that with contact.
  EXPECT_GT(go.max_closure, 3.0 * gw.max_closure);
}

// The Euler predictor's tangent (EvaluationMode::touching_closed, docs/theory/newton.md,
// "Predictor"): in the reference state of two touching blocks each vertical neighbour pair
// across the interface sits at the edge of its gate (|Y| = delta_c = dx), open, without force
// or stiffness. With the flag on, exactly those pairs get the Jacobian of a stuck pair at full
// gate, (C/a) n n^T + k_t t t^T; the residual does not change, and the flag off restores them.
TEST(TouchingPredictor, ClosesTouchingPairsInTheTangentOnly) {
  BlocksSpec spec;
  spec.nx = 12;
  spec.ny = 8;
  spec.press = 0.1 * spec.dx;
  spec.friction = 0.5;
  const Scene scene = test::scene_from_yaml(blocks_yaml(spec));
  const Model model = discretise(scene);
  QuasiStaticProblem problem(model, problem_options(scene));
  problem.set_load_factor(0.0);
  const VectorXd x = VectorXd::Zero(problem.n_unknowns());
  SparseMatrix K = problem.make_tangent();
  VectorXd r_plain, r_closed;
  problem.evaluate(x, r_plain, &K);
  const ContactSystem& c = *problem.contact();
  EXPECT_EQ(c.counts().active(), 0) << "no pair carries a force in the reference state";
  ASSERT_TRUE(problem.set_evaluation_mode(EvaluationMode::touching_closed));
  problem.evaluate(x, r_closed, &K);
  const ContactLaw& law = c.law();
  int touching = 0;
  for (Index k = 0; k < c.size(); ++k) {
    const ContactPair& pr = c.pairs()[k];
    const Vec2 X = model.particles.position[pr.j] - model.particles.position[pr.i];
    const bool touches = X.norm() <= law.radius * (1.0 + 1e-9);
    touching += touches;
    const PairResult& res = c.result(k);
    EXPECT_EQ(res.normal_force, 0.0);
    if (!touches) {
      EXPECT_EQ(res.status, PairStatus::open) << "pair " << k << " at " << X.norm() / spec.dx << " dx";
      continue;
    }
    EXPECT_EQ(res.status, PairStatus::stick);
    const double kn = pr.stiffness / pr.gap0;
    const Mat2 expected = kn * pr.normal * pr.normal.transpose() +
                          law.tangential_factor * kn * pr.tangent() * pr.tangent().transpose();
    // The same expression evaluated in the same order: equal to round-off.
    EXPECT_LE((res.J - expected).norm(), 1e-12 * expected.norm()) << "pair " << k;
  }
  // The touching pairs are the vertical neighbours across y = H: one per column of real
  // particles (the blocks' fictitious layers sit at the loaded edges, not at the interface).
  EXPECT_EQ(touching, spec.nx);
  EXPECT_EQ(c.counts().stick, spec.nx);
  EXPECT_EQ((r_closed - r_plain).norm(), 0.0) << "the flag changes the tangent only";
  ASSERT_TRUE(problem.set_evaluation_mode(EvaluationMode::standard));
  problem.evaluate(x, r_closed, &K);
  EXPECT_EQ(c.counts().active(), 0);
}

// Case 4.1 coarse (dx = 0.8 mm): in step 1 the right plate is pushed 0.5 dx into the left one.
// The contact-free Euler predictor would move it through, closing every facing pair at once
// with slip (the left plate pulled up 0.5 dx), and Newton then spent its iterations finding
// which pairs close and stick with line-search steps down to 1/8; with touching pairs closed
// and stuck in the predictor's tangent, the first iterate already has the final open set.
TEST(TouchingPredictor, SlidingPlatesFindTheirActiveSetInStepOne) {
  auto s = test::solve_case("paper_4_1_sliding_plates", {"discretization.spacing=8e-4"});
  ASSERT_TRUE(s->run.completed) << s->run.message;
  const StepReport& first = s->steps.front();
  std::printf("case 4.1, dx = 0.8 mm, step 1: %d Newton iterations, %d active-set changes, first residual %.3g\n",
              first.newton_iterations, first.active_set_changes, first.residuals.front());
  // Measured 5 Newton iterations (8 with the contact-free predictor; at paper resolution 5
  // against 11) and a first relative residual of 0.51 (1.0 before).
  EXPECT_LE(first.newton_iterations, 6);
  EXPECT_LT(first.residuals.front(), 0.7);
  // The V-cycle kept from the unloaded state has no contact blocks; the predictor renews it
  // with the pairs it closes. Measured 315 Krylov iterations over the four steps (387 with
  // the unloaded state's V-cycle kept, 418 with the contact-free predictor).
  int krylov = 0;
  for (const StepReport& r : s->steps) krylov += r.linear_iterations;
  std::printf("Krylov iterations over %zu steps: %d; V-cycle set-ups in step 1: %d\n", s->steps.size(), krylov,
              first.factorizations);
  EXPECT_LE(krylov, 350);
  // The unloaded state's V-cycle is set up only when a solve needs it, so the renewal replaces
  // it before it is built: one set-up in step 1, not two.
  EXPECT_EQ(first.factorizations, 1);
}

}  // namespace
}  // namespace peristat
