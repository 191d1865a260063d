// ADR, the explicit path, against known answers and against Newton (issue 4). ADR solves
// the same discrete problem as Newton (same Problem, same residual, same friction return
// map), so converged to a relative residual of 1e-8 the two must agree to far better than
// the 1e-4 the issue asks. The error bounds are 18x to 34x the values measured on 2026-11-23
// (one thread), so that a real regression fails; each test prints them and how long ADR ran.
#include <cmath>
#include <sstream>

#include <gtest/gtest.h>

#include "support/scenes.hpp"
#include "support/solve.hpp"

namespace peristat {
namespace {

double relative_difference(const test::Solved& a, const test::Solved& b) {
  double num = 0.0, den = 0.0;
  const Particles& p = b.model.particles;
  for (Index i = 0; i < p.size(); ++i) {
    if (p.fictitious[i]) continue;
    num += (Vec2(a.u[2 * i], a.u[2 * i + 1]) - Vec2(b.u[2 * i], b.u[2 * i + 1])).squaredNorm();
    den += Vec2(b.u[2 * i], b.u[2 * i + 1]).squaredNorm();
  }
  return std::sqrt(num / den);
}

// The patch test (an affine field on 8 surrounding layers; the exact answer is that field,
// verification.Patch*): ADR reaches it, and its residual falls monotonically on average.
// "On average": the history, sampled every iteration, is cut into 10 windows of equal
// length; the mean log10 residual of each window is below that of the window before. (ADR's
// residual is not monotone iterate by iterate: it is a damped oscillation.)
TEST(Adr, PatchTestConvergesToTheAffineField) {
  const Mat2 G = (Mat2() << 1.0e-3, 4.0e-4, -2.0e-4, -5.0e-4).finished();
  std::ostringstream b;
  b.precision(17);
  b << "  - {body: plate, surround: true, layers: 8, ux: {value: 0, grad: [" << G(0, 0) << ", " << G(0, 1)
    << "]}, uy: {value: 0, grad: [" << G(1, 0) << ", " << G(1, 1) << "]}}\n";
  test::PlateSpec spec;
  spec.nx = 16;
  spec.ny = 12;
  spec.kinematics = "small";
  spec.boundary = b.str();
  spec.solver = "  type: adr\n  adr: {rtol: 1.0e-10, report_every: 1}\n";
  auto s = test::solve_scene(test::plate_yaml(spec));
  ASSERT_TRUE(s->run.completed) << s->run.message;
  double err = 0.0, ref = 0.0;
  for (Index i = 0; i < s->model.particles.size(); ++i) {
    if (s->model.particles.fictitious[i]) continue;
    const Vec2 exact = G * s->model.particles.position[i];
    err = std::max(err, (Vec2(s->u[2 * i], s->u[2 * i + 1]) - exact).norm());
    ref = std::max(ref, exact.norm());
  }
  const std::vector<double>& h = s->steps.at(0).residuals;
  const int windows = 10;
  const std::size_t w = h.size() / windows;
  ASSERT_GE(w, 2u) << "too short a history: " << h.size();
  std::vector<double> mean(windows, 0.0);
  for (int k = 0; k < windows; ++k) {
    for (std::size_t i = k * w; i < (k + 1) * w; ++i) mean[k] += std::log10(h[i]) / w;
  }
  std::printf("ADR patch test: %ld iterations, %.3f s, max error / max |u| = %.3e; window means of log10 r:",
              s->iterations(), s->seconds, err / ref);
  for (double m : mean) std::printf(" %.2f", m);
  std::printf("\n");
  // Measured 5.7e-11 on 2026-11-23; bound 1e-9 (18x). The residual 1e-10 times the
  // condition number of this small stiffness (~1e3) would allow 1e-7.
  EXPECT_LT(err / ref, 1e-9);
  for (int k = 1; k < windows; ++k) EXPECT_LT(mean[k], mean[k - 1]) << "window " << k;
  EXPECT_LE(h.back(), 1e-10);  // the rtol: converged (measured 7.8e-11 on 2026-11-23)
}

// A uniaxial tension plate in both kinematics: ADR at rtol 1e-8 against Newton at 1e-12.
TEST(Adr, AgreesWithNewtonOnTheTensionPlate) {
  for (const char* kin : {"small", "finite"}) {
    test::PlateSpec spec;
    spec.nx = 40;
    spec.ny = 20;
    spec.kinematics = kin;
    spec.steps = 2;
    spec.boundary = test::tension_boundary(1e-3, spec);
    spec.solver = "  newton: {rtol: 1.0e-12}\n";
    auto newton = test::solve_scene(test::plate_yaml(spec));
    spec.solver = "  type: adr\n  adr: {rtol: 1.0e-8}\n";
    auto adr = test::solve_scene(test::plate_yaml(spec));
    ASSERT_TRUE(newton->run.completed && adr->run.completed) << adr->run.message;
    const double d = relative_difference(*adr, *newton);
    std::printf(
        "tension plate, %s kinematics: ADR %ld iterations in %.3f s (Newton %ld in %.3f s); "
        "relative L2 difference %.3e\n",
        kin, adr->iterations(), adr->seconds, newton->iterations(), newton->seconds, d);
    // Measured 1.12e-8 (small) and 1.09e-8 (finite) on 2026-11-23; bound 3e-7 (27x).
    EXPECT_LT(d, 3e-7);
  }
}

// The paper's cases at coarser spacing, every contact variant the issue names. ADR and Newton
// share the friction return map, so they solve the same discrete problem.
void compare_case(const std::string& name, const std::vector<std::string>& common,
                  const std::vector<std::string>& variant, double bound) {
  std::vector<std::string> n = common, a = common;
  n.insert(n.end(), variant.begin(), variant.end());
  a.insert(a.end(), variant.begin(), variant.end());
  n.push_back("solver.newton.rtol=1e-12");
  n.push_back("solver.linear=umfpack");
  a.push_back("solver.type=adr");
  a.push_back("solver.adr.rtol=1e-8");
  auto newton = test::solve_case(name, n);
  auto adr = test::solve_case(name, a);
  ASSERT_TRUE(newton->run.completed) << newton->run.message;
  ASSERT_TRUE(adr->run.completed) << adr->run.message;
  const double d = relative_difference(*adr, *newton);
  std::string label;
  for (const std::string& v : variant) label += " " + v;
  std::printf(
      "%s%s: ADR %ld iterations in %.2f s, Newton %ld iterations in %.2f s; relative L2 difference %.3e\n",
      name.c_str(), label.c_str(), adr->iterations(), adr->seconds, newton->iterations(), newton->seconds, d);
  EXPECT_LT(d, bound);
}

TEST(Adr, AgreesWithNewtonOnCase41Coarse) {
  // dx = 2 mm: 16 x 30 particles per plate (the paper: 0.4 mm, 80 x 150).
  const std::vector<std::string> common = {"discretization.spacing=2e-3"};
  // Measured 8.9e-9 (f_c = 0.8) and 5.9e-9 (f_c = 0.01) on 2026-11-23; bound 3e-7 (34x).
  constexpr double bound = 3e-7;
  compare_case("paper_4_1_sliding_plates", common, {"contact.friction=0.8"}, bound);
  compare_case("paper_4_1_sliding_plates", common, {"contact.friction=0.01"}, bound);
}

// Exact enforcement (docs/theory/contact.md, section 8): both solvers run the same multiplier
// updates between solves, each update computed from a state converged to 1e-8 or better, so
// they take the same sequence and end at the same state (the issue asks for 1e-6).
TEST(Adr, AgreesWithNewtonWithExactContact) {
  constexpr double bound = 1e-6;
  compare_case("paper_4_1_sliding_plates", {"discretization.spacing=2e-3"},
               {"contact.friction=0", "contact.enforcement=exact"}, bound);
  compare_case("paper_4_1_sliding_plates", {"discretization.spacing=2e-3"},
               {"contact.friction=0.8", "contact.enforcement=exact"}, bound);
  compare_case("paper_4_3_precracked_plate", {"discretization.spacing=0.02"},
               {"contact.friction=0.8", "contact.enforcement=exact"}, bound);
}

TEST(Adr, AgreesWithNewtonOnCase43Coarse) {
  // dx = 20 mm: 50 x 50 particles (the paper: 10 mm, 100 x 100).
  const std::vector<std::string> common = {"discretization.spacing=0.02"};
  // Measured 3.4e-8 (no contact), 1.7e-8 (frictionless) and 1.7e-8 (f_c = 0.8) on
  // 2026-11-23; bound 1e-6 (30x the largest).
  constexpr double bound = 1e-6;
  compare_case("paper_4_3_precracked_plate", common, {"contact.enabled=false"}, bound);
  compare_case("paper_4_3_precracked_plate", common, {"contact.friction=0"}, bound);
  compare_case("paper_4_3_precracked_plate", common, {"contact.friction=0.8"}, bound);
}

}  // namespace
}  // namespace peristat
