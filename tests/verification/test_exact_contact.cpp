// Exact contact enforcement (contact.enforcement: exact, docs/theory/contact.md section 8)
// against the continuum on the paper's sliding plates, and the contact stiffness swept over
// five decades with both enforcements: a run either completes with no crossed pair or stops
// with exit code 3, never a crossed completed state (issue 12). The geometric checks here are
// computed from the displacements, independently of the program's own checks.
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "support/scenes.hpp"
#include "support/solve.hpp"

namespace peristat {
namespace {

/// Over the candidate pairs at displacement u: the largest closure (a - n.Y) / a of a pair
/// whose cells face each other (a <= dx, |t.Y| < dx), the smallest n.Y / dx of such a pair
/// (negative: it has crossed), and the number of crossed pairs.
struct Facing {
  double max_closure = 0.0, min_normal = 1e300;
  int crossed = 0;
};
Facing facing_pairs(const test::Solved& s) {
  Facing f;
  const double dx = s.model.spacing;
  const Particles& p = s.model.particles;
  for (const ContactPair& c : s.problem->contact()->pairs()) {
    const Vec2 Y = p.position[c.j] - p.position[c.i] +
                   Vec2(s.u[2 * c.j] - s.u[2 * c.i], s.u[2 * c.j + 1] - s.u[2 * c.i + 1]);
    const double yn = c.normal.dot(Y), yt = std::abs(Vec2(-c.normal.y(), c.normal.x()).dot(Y));
    if (yt >= dx) continue;
    if (yn < 0.0) ++f.crossed;
    if (c.gap0 > dx * (1 + 1e-9)) continue;
    f.max_closure = std::max(f.max_closure, (c.gap0 - yn) / c.gap0);
    f.min_normal = std::min(f.min_normal, yn / dx);
  }
  return f;
}

/// Particles of the left plate's interface column (reference x within half a spacing of
/// x_face - dx/2) whose current height lies inside [y_lo, y_hi], and how many of them have no
/// candidate pair whose cells face each other (|t.Y| < dx) at the end.
std::pair<int, int> partnerless(const test::Solved& s, double x_face, double y_lo, double y_hi) {
  const Particles& p = s.model.particles;
  const double dx = s.model.spacing;
  const ContactSystem& c = *s.problem->contact();
  int column = 0, without = 0;
  for (Index i = 0; i < p.size(); ++i) {
    if (p.fictitious[i] || p.body[i] != 0 || std::abs(p.position[i].x() - (x_face - 0.5 * dx)) > 0.25 * dx) continue;
    const double y = p.position[i].y() + s.u[2 * i + 1];
    if (y < y_lo || y > y_hi) continue;
    ++column;
    bool found = false;
    for (auto e = c.incident_begin(i); e != c.incident_end(i) && !found; ++e) {
      const ContactPair& pr = c.pairs()[e->pair];
      const Vec2 Y = p.position[pr.j] - p.position[pr.i] +
                     Vec2(s.u[2 * pr.j] - s.u[2 * pr.i], s.u[2 * pr.j + 1] - s.u[2 * pr.i + 1]);
      found = std::abs(pr.tangent().dot(Y)) < dx;
    }
    without += !found;
  }
  return {column, without};
}

/// Mean of u_c over the real particles of body b in the box [lo, hi].
double mean_u(const test::Solved& s, int b, int component, const Vec2& lo, const Vec2& hi) {
  const Particles& p = s.model.particles;
  double sum = 0.0;
  int n = 0;
  for (Index i = 0; i < p.size(); ++i) {
    const Vec2& X = p.position[i];
    if (p.fictitious[i] || p.body[i] != b || X.x() < lo.x() || X.x() > hi.x() || X.y() < lo.y() ||
        X.y() > hi.y())
      continue;
    sum += s.u[2 * i + component];
    ++n;
  }
  EXPECT_GT(n, 0);
  return sum / n;
}

// Frictionless case 4.1 at the paper's spacing. The continuum: both plates in uniaxial stress
// sigma_x = -E 0.8 / 64 = -750 MPa; the relative slide of the interface is
// 0.8 - 60 nu |eps_x| = 0.65 mm if the plates stayed rectangular. They do not quite: the
// plates' ends are offset by the slide, so the contact force acts 0.33 mm off the grips'
// line and the plates bend (a moment P e, sigma varying by +-6 e / h ~ +-3% over the height,
// and the interface rotating by ~5e-4). Both effects vanish at mid-height for the stress
// (point symmetry about the plates' common centre), not for the slide.
//   sigma_x at mid-height (strain fitted over the interior, 10 dx from every edge, between
//   y = 27 and 33 mm): within 1% of -750 MPa (measured -750.6 MPa with the surface
//   correction; -745.3 MPa without).
//   slide over the middle 80% of the interface: within 3% of 0.65 mm in every band (the
//   bending above; measured 2.7%, 2.2% without the correction), and the mean within 1% of
//   0.643 mm, the continuum's value extrapolated from exact runs at dx = 0.8, 0.4 and 0.2 mm:
//   with the surface correction means 0.6349, 0.6387, 0.6408 mm (Richardson, observed order
//   0.9: 0.6433 mm); without it 0.6383, 0.6411, 0.6421 mm (order 1.5: 0.6427 mm). The two
//   models agree on the limit to 0.1%; the bending above lowers the slide by 1.1%
//   (docs/cases.md). Measured 0.6387 mm (-0.7%).
//   closure of every facing pair within the tolerance (1e-3), no crossed pair.
TEST(ExactContact, SlidingPlatesMatchTheContinuumAtPaperResolution) {
  auto s = test::solve_case("paper_4_1_sliding_plates", {"contact.friction=0", "contact.enforcement=exact"});
  ASSERT_TRUE(s->run.completed) << s->run.message;
  const Facing f = facing_pairs(*s);
  const double dx = s->model.spacing, E = 60e9;
  const double eps_left = test::fit_affine(*s, 0, Vec2(10 * dx, 0.027), Vec2(0.032 - 10 * dx, 0.033))[1];
  const double eps_right = test::fit_affine(*s, 0, Vec2(0.032 + 10 * dx, 0.027), Vec2(0.064 - 10 * dx, 0.033))[1];
  // Slide: left column x = 31.8 mm minus right column 32.2 mm, rows 6..54 mm, in 8 bands.
  double worst = 0.0, mean = 0.0;
  for (int b = 0; b < 8; ++b) {
    const double y0 = 0.006 + b * 0.006, y1 = y0 + 0.006;
    const double slide = mean_u(*s, 0, 1, Vec2(0.032 - dx, y0), Vec2(0.032, y1)) -
                         mean_u(*s, 1, 1, Vec2(0.032, y0), Vec2(0.032 + dx, y1));
    mean += slide / 8;
    worst = std::max(worst, std::abs(slide / 0.65e-3 - 1.0));
  }
  std::printf(
      "exact, frictionless 4.1: sigma_x at mid-height %.2f / %.2f MPa, slide mean %.5f mm (worst band %.4f "
      "from 0.65 mm), largest closure %.2e, min n.Y %.4f dx, crossed %d; %.1f s\n",
      E * eps_left / 1e6, E * eps_right / 1e6, mean * 1e3, worst, f.max_closure, f.min_normal, f.crossed,
      s->seconds);
  EXPECT_NEAR(E * eps_left / -750e6, 1.0, 0.01);
  EXPECT_NEAR(E * eps_right / -750e6, 1.0, 0.01);
  EXPECT_LT(worst, 0.03);
  EXPECT_NEAR(mean / 0.643e-3, 1.0, 0.01);
  EXPECT_LT(f.max_closure, 1e-3 * (1 + 1e-9));
  EXPECT_EQ(f.crossed, 0);
  // After its 1.6 dx slide, every particle of the left face that still faces the right
  // plate (current height one spacing inside the right plate's ends) has a partner.
  const auto [column, without] = partnerless(*s, 0.032, dx, 0.06 - dx);
  std::printf("facing particles of the left face: %d, without a partner: %d\n", column, without);
  EXPECT_GT(column, 140);
  EXPECT_EQ(without, 0) << "of " << column;
}

// Large sliding (docs/theory/contact.md, section 10): case 4.1's plates at dx = 1 mm, the
// left one pulled up by 6 mm instead of 0.8 (a slide of 5.85 dx, twice the reach of the
// reference candidates), frictionless and exact, in 12 steps. The faces are searched again
// as they slide; every particle of the left face that still faces the right plate has a
// partner at the end, no pair has crossed, every facing pair is closed to the tolerance, and
// the relative slide in the middle of the interface is the imposed 6 mm less the two plates'
// Poisson expansion, 6 - 60 nu |eps_x| = 5.85 mm, less the bending of case 4.1 (1.1% of the
// 0.65 mm there, ~7 um): within 0.5% of 5.85 mm.
TEST(ExactContact, LargeSlideKeepsAPartnerForEveryFacingParticle) {
  const std::string yaml =
      test::large_slide_yaml("6.0e-3", "friction: 0\n  enforcement: exact", "solver: {linear: cg}\n");
  auto s = test::solve_scene(yaml);
  ASSERT_TRUE(s->run.completed) << s->run.message;
  const ContactSystem& c = *s->problem->contact();
  const Facing f = facing_pairs(*s);
  const double dx = s->model.spacing;
  const auto [column, without] = partnerless(*s, 0.032, dx, 0.06 - dx);
  const double slide = mean_u(*s, 0, 1, Vec2(0.032 - dx, 0.02), Vec2(0.032, 0.04)) -
                       mean_u(*s, 1, 1, Vec2(0.032, 0.02 - 6e-3), Vec2(0.032 + dx, 0.04 - 6e-3));
  std::printf(
      "large slide: %d searches, %ld candidates, %d of %d facing particles without a partner, largest closure "
      "%.2e, crossed %d, slide %.4f mm; %.1f s\n",
      c.searches(), long(c.size()), without, column, f.max_closure, f.crossed, slide * 1e3, s->seconds);
  EXPECT_GE(c.searches(), 5);
  EXPECT_GT(column, 50);
  EXPECT_EQ(without, 0);
  EXPECT_EQ(f.crossed, 0);
  EXPECT_LT(f.max_closure, 1e-3 * (1 + 1e-9));
  EXPECT_NEAR(slide / 5.85e-3, 1.0, 0.005);
}

// The contact stiffness from 1e-2 to 1e3 x E on frictionless case 4.1 at dx = 2 mm (every
// decade) and 1 mm (three of them, to keep the suite short), both enforcements. Every run either completes with no crossed pair, or stops (exit code 3
// in the program) -- never a completed crossed state. Exact runs close every facing pair to
// the tolerance and agree with each other: a closure or a force-carrying gap of at most 1e-3
// of a spacing at each pair moves the field by about that much, 1e-3 dx against the 0.8 mm
// (0.4 dx at 2 mm) imposed: 5e-3 relative at most (measured 2e-3).
TEST(ExactContact, StiffnessSweepNeverCompletesCrossed) {
  const std::vector<const char*> every = {"6e8", "6e9", "6e10", "6e11", "6e12", "6e13"};
  const std::vector<const char*> some = {"6e8", "6e11", "6e13"};
  for (const char* spacing : {"2e-3", "1e-3"}) {
    VectorXd reference;
    for (const char* enforcement : {"penalty", "exact"}) {
      for (const char* stiffness : std::string(spacing) == "2e-3" ? every : some) {
        auto s = test::solve_case("paper_4_1_sliding_plates",
                                  {"contact.friction=0", std::string("discretization.spacing=") + spacing,
                                   std::string("contact.enforcement=") + enforcement,
                                   std::string("contact.stiffness=") + stiffness});
        const Facing f = facing_pairs(*s);
        double difference = 0.0;
        if (std::string(enforcement) == "exact" && s->run.completed) {
          if (reference.size() == 0) reference = s->u;
          difference = (s->u - reference).norm() / reference.norm();
        }
        std::printf(
            "dx %s, %s, E_c %s: %s; largest closure %.3e, min n.Y %.4f dx, crossed %d, %ld iterations in "
            "%.1f s; difference from the first exact run %.2e\n",
            spacing, enforcement, stiffness, s->run.completed ? "completed" : s->run.message.c_str(),
            f.max_closure, f.min_normal, f.crossed, s->iterations(), s->seconds, difference);
        if (!s->run.completed) continue;  // stopped with a reason: allowed
        EXPECT_EQ(f.crossed, 0) << spacing << " " << enforcement << " " << stiffness;
        if (std::string(enforcement) == "exact") {
          EXPECT_LT(f.max_closure, 1e-3 * (1 + 1e-9)) << spacing << " " << stiffness;
          EXPECT_LT(difference, 5e-3) << spacing << " " << stiffness;
        }
      }
    }
  }
}

}  // namespace
}  // namespace peristat
