// Quasi-static bond breaking (issue 5, first part): no bond breaks below the threshold,
// the first bonds to break sit at the notch tip, and Newton and ADR break the same bonds.
#include <cmath>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "contact/contact.hpp"
#include "discretisation/model.hpp"
#include "materials/failure.hpp"
#include "support/scenes.hpp"
#include "support/solve.hpp"

namespace peristat {
namespace {

// The edge-notched plate of test::notch_yaml (small kinematics, one load step).
std::string notch(double pull, bool failure, const std::string& solver = "{linear: umfpack}",
                  const std::string& extra = "") {
  return test::notch_yaml(pull, failure, solver, extra);
}

TEST(Failure, NoBondBreaksBelowTheThreshold) {
  // 2e-5 m: the largest bond stretch (at the notch tip) stays below s_c.
  auto with = test::solve_scene(notch(2e-5, true));
  auto without = test::solve_scene(notch(2e-5, false));
  ASSERT_TRUE(with->run.completed && without->run.completed);
  EXPECT_EQ(with->problem->failure()->broken(), 0);
  EXPECT_EQ(with->steps.at(0).resolves, 0);
  // Checking the criterion changes nothing else: the same answer to round-off.
  EXPECT_LT((with->u - without->u).norm(), 1e-12 * without->u.norm());
}

TEST(Failure, FirstBondsBreakAtTheNotchTip) {
  auto s = test::solve_scene(notch(2.5e-5, true));
  ASSERT_TRUE(s->run.completed) << s->run.message;
  VectorXd d;
  s->problem->failure()->damage(d);
  const Vec2 tip(0.015, 0.01);
  const double delta = 3e-3;
  int damaged = 0;
  double far = 0.0, off_line = 0.0, behind = 0.0, ahead = 0.0;
  for (Index i = 0; i < d.size(); ++i) {
    if (d[i] <= 0.0) continue;
    ++damaged;
    far = std::max(far, (s->model.particles.position[i] - tip).norm());
    const Vec2& X = s->model.particles.position[i];
    off_line = std::max(off_line, std::abs(X.y() - tip.y()));
    behind = std::max(behind, tip.x() - X.x());
    ahead = std::max(ahead, X.x() - tip.x());
  }
  std::printf(
      "notch, pull 2.5e-5 m: %ld bonds broken in %d re-solves; %d damaged particles, farthest %.2f delta "
      "from the tip, %.2f delta off the notch line, %.2f delta behind and %.2f delta ahead of the tip\n",
      static_cast<long>(s->problem->failure()->broken()), s->steps.at(0).resolves, damaged, far / delta,
      off_line / delta, behind / delta, ahead / delta);
  EXPECT_GT(s->problem->failure()->broken(), 0);
  EXPECT_GE(s->steps.at(0).resolves, 1);
  // The crack starts at the tip and runs along the notch line: every damaged particle (an
  // end of a broken bond) lies within one horizon of the line and no more than one horizon
  // behind the tip. How far it runs at this load depends on the model (uncorrected: 1.2
  // delta; with the surface correction, whose crack faces are as stiff as the bulk, 2.5
  // delta ahead): asserted below 4 delta, well inside the 40 mm plate.
  EXPECT_LE(off_line, delta);
  EXPECT_LE(behind, delta);
  EXPECT_LT(ahead, 4.0 * delta);
}

TEST(Failure, NewtonAndAdrBreakTheSameBonds) {
  auto newton = test::solve_scene(notch(2.5e-5, true, "{linear: umfpack, newton: {rtol: 1.0e-12}}"));
  auto adr = test::solve_scene(notch(2.5e-5, true, "{type: adr, adr: {rtol: 1.0e-10}}"));
  ASSERT_TRUE(newton->run.completed && adr->run.completed) << adr->run.message;
  VectorXd dn, da;
  newton->problem->failure()->damage(dn);
  adr->problem->failure()->damage(da);
  std::printf(
      "Newton broke %ld bonds in %d re-solves, ADR %ld in %d (%ld ADR iterations); max damage difference "
      "%.3e\n",
      static_cast<long>(newton->problem->failure()->broken()), newton->steps.at(0).resolves,
      static_cast<long>(adr->problem->failure()->broken()), adr->steps.at(0).resolves, adr->iterations(),
      (dn - da).cwiseAbs().maxCoeff());
  EXPECT_EQ(newton->problem->failure()->broken(), adr->problem->failure()->broken());
  EXPECT_EQ((dn - da).cwiseAbs().maxCoeff(), 0.0);  // the same bonds, hence the same damage
}

// ADR with bonds broken at every pseudo-time step (solver.adr.breaking: iterations, the
// explicit codes' procedure) on the notch pulled in 20 steps (each increment jumps the grip by
// 1/20 of the pull; in one step the jump alone breaks the grip's bonds, docs/theory/adr.md):
// - the first bonds break in the same load step as between equilibria (step 17 of 20 with
//   Newton): a small increment's transient does not reach the criterion early;
// - no re-solves, and the converged state of the last step has no intact bond over the
//   criterion (checked again there: nothing left to break);
// - no broken bond reaches the grips: no damage within a horizon of the top and bottom edges
//   (between equilibria the damage stays within one horizon of the notch line; the transient
//   spreads it to 6.5 mm, 2.2 horizons, of the line's 10 mm to either edge).
// How many break differs from Newton's count (measured 909 against 221): the transient after
// each round is not an equilibrium, and the crack runs further in it; printed, not asserted.
TEST(Failure, AdrBreakingDuringTheIterationsLeavesNothingOverTheCriterion) {
  const std::string steps = "{steps: 20}";
  auto newton = test::solve_scene(
      test::notch_yaml(2.5e-5, true, "{linear: umfpack, newton: {rtol: 1.0e-12}}", "", "small", steps));
  auto adr = test::solve_scene(
      test::notch_yaml(2.5e-5, true, "{type: adr, adr: {rtol: 1.0e-10, breaking: iterations}}", "", "small", steps));
  ASSERT_TRUE(newton->run.completed && adr->run.completed) << adr->run.message;
  const auto first_breaking = [](const test::Solved& s) {
    for (std::size_t k = 0; k < s.steps.size(); ++k)
      if (s.steps[k].bonds_broken > 0) return static_cast<int>(k) + 1;
    return 0;
  };
  const Index nb = newton->problem->failure()->broken(), ab = adr->problem->failure()->broken();
  std::printf("notch, pull 2.5e-5 m in 20 steps: between equilibria %ld bonds, first in step %d; during the ADR "
              "iterations %ld, first in step %d\n",
              static_cast<long>(nb), first_breaking(*newton), static_cast<long>(ab), first_breaking(*adr));
  EXPECT_GT(first_breaking(*newton), 0);
  EXPECT_EQ(first_breaking(*adr), first_breaking(*newton));
  Index counted = 0;
  for (const StepReport& step : adr->steps) {
    EXPECT_EQ(step.resolves, 0);
    counted += step.bonds_broken;
  }
  EXPECT_EQ(counted, ab);
  EXPECT_EQ(adr->problem->advance_irreversible_state(adr->x, 0), 0);
  VectorXd d;
  adr->problem->failure()->damage(d);
  const double delta = 3e-3;
  double off_line = 0.0;
  for (Index i = 0; i < d.size(); ++i) {
    const double y = adr->model.particles.position[i].y();
    if (d[i] <= 0.0 || adr->model.particles.fictitious[i]) continue;
    off_line = std::max(off_line, std::abs(y - 0.01));
    EXPECT_GT(y, delta);
    EXPECT_LT(y, 0.02 - delta);
  }
  std::printf("damage reaches %.1f mm from the notch line\n", off_line * 1e3);
}

// Broken bonds join the contact candidates at once (paper section 4.4), so new faces can
// close: with contact on, the candidate count grows by exactly the bonds broken (none of
// them has a fictitious end here), and the run is otherwise the same (the faces open in
// tension: no new pair is in contact, so the same bonds break).
TEST(Failure, BrokenBondsBecomeContactCandidates) {
  auto plain = test::solve_scene(notch(2.5e-5, true));
  auto with = test::solve_scene(notch(2.5e-5, true, "{linear: umfpack}", "contact: {friction: 0.3}\n"));
  ASSERT_TRUE(plain->run.completed && with->run.completed) << with->run.message;
  auto before = test::solve_scene(notch(1e-6, false, "{linear: umfpack}", "contact: {friction: 0.3}\n"));
  const Index initial = before->problem->contact()->size();
  const ContactCounts& c = with->problem->contact()->counts();
  std::printf("contact candidates: %ld from the notch, %ld after %ld bonds broke; %ld in contact\n",
              static_cast<long>(initial), static_cast<long>(c.candidates),
              static_cast<long>(with->problem->failure()->broken()), static_cast<long>(c.active()));
  EXPECT_EQ(c.candidates, initial + with->problem->failure()->broken());
  EXPECT_EQ(with->problem->failure()->broken(), plain->problem->failure()->broken());
  EXPECT_EQ(c.active(), 0);
}

// A scene whose contact pairs are all broken bonds (no pre-crack, no interface) starts with no
// candidate. Its broken-bond pairs must still carry Coulomb friction and a slip history: until
// 2026-11-28 the slip state was sized from the initial pairs, so such a scene evaluated every
// later pair without friction, silently. One pair of neighbours 3 dx from the edges, closed to
// half a spacing and sheared by a fifth: with friction 0.3 it carries a tangential force, and
// the checkpoint holds its slip; with friction 0 the tangential force is exactly zero.
TEST(Failure, BrokenBondPairsWithoutAnInitialCandidateHaveFriction) {
  double tangential[2] = {0.0, 0.0};
  for (const double friction : {0.0, 0.3}) {
    std::string yaml =
        notch(1e-6, true, "{linear: umfpack}", "contact: {friction: " + std::to_string(friction) + "}\n");
    const std::size_t at = yaml.find("cracks:");
    ASSERT_NE(at, std::string::npos);
    yaml.erase(at, yaml.find("boundary:") - at);  // no pre-crack: no initial candidate
    const Scene scene = test::scene_from_yaml(yaml);
    const Model model = discretise(scene);
    ContactSystem contact(model, scene.contact);
    ASSERT_EQ(contact.size(), 0);
    const double dx = model.spacing;
    Index i = -1, j = -1;
    for (Index p = 0; p < model.particles.size() && j < 0; ++p)
      if ((model.particles.position[p] - Vec2(0.0205, 0.0105)).norm() < 0.25 * dx) i = p;  // a cell centre
    ASSERT_GE(i, 0);
    for (Index p = 0; p < model.particles.size(); ++p)
      if ((model.particles.position[p] - model.particles.position[i] - Vec2(dx, 0.0)).norm() < 0.25 * dx)
        j = p;
    ASSERT_GE(j, 0);
    VectorXd u = VectorXd::Zero(2 * model.particles.size());
    contact.add_broken_bonds({{i, j}}, u);
    contact.commit(u);
    ASSERT_EQ(contact.size(), 1);
    u[2 * j] = -0.5 * dx;     // closed to half a spacing along the bond
    u[2 * j + 1] = 0.2 * dx;  // and sheared
    contact.evaluate(u, false);
    ASSERT_GT(contact.result(0).normal_force, 0.0) << "the pair is closed";
    tangential[friction > 0.0] = contact.result(0).tangential;
    StateArchive archive;
    contact.save(archive);
    EXPECT_EQ(archive.arrays.count("contact/slip"), friction > 0.0 ? 1u : 0u);
  }
  EXPECT_EQ(tangential[0], 0.0);
  EXPECT_GT(std::abs(tangential[1]), 0.0);
}

// Undoing a breaking round (what load stepping does when its re-solve fails) restores the
// problem exactly: the same residual bit for bit, the same contact candidates, no bond
// counted as broken. A random state with displacements of 5% of dx puts most bonds over
// s_c = 2.1e-3; 25 of them break.
TEST(Failure, UndoingARoundRestoresTheProblemExactly) {
  const Scene scene =
      test::scene_from_yaml(notch(1e-6, true, "{linear: umfpack}", "contact: {friction: 0.3}\n"));
  const Model model = discretise(scene);
  QuasiStaticProblem problem(model, problem_options(scene));
  problem.set_load_factor(1.0);
  VectorXd x = VectorXd::Zero(problem.n_unknowns());
  for (Index i = 0; i < x.size(); ++i) x[i] = 5e-5 * std::sin(1.7 * static_cast<double>(i));
  VectorXd before, after;
  problem.evaluate(x, before, nullptr);
  const Index candidates = problem.contact()->size();
  ASSERT_EQ(problem.advance_irreversible_state(x, 25), 25);
  EXPECT_EQ(problem.failure()->broken(), 25);
  EXPECT_GT(problem.contact()->size(), candidates);
  VectorXd broken;
  problem.evaluate(x, broken, nullptr);
  EXPECT_GT((broken - before).norm(), 0.0);  // the round changed the problem
  problem.revert_irreversible_state();
  problem.evaluate(x, after, nullptr);
  EXPECT_EQ(problem.failure()->broken(), 0);
  EXPECT_EQ(problem.contact()->size(), candidates);
  EXPECT_TRUE((after.array() == before.array()).all());
  VectorXd d;
  problem.failure()->damage(d);
  EXPECT_EQ(d.maxCoeff(), 0.0);
}

// The same with the critical skew: a round that breaks reference bonds gives their
// particles new, intact references (docs/theory/failure.md), and undoing it restores the
// old ones, so that the same round can be taken again bond for bond with the same peak.
TEST(Failure, UndoingASkewRoundRestoresTheReferences) {
  const Scene scene = test::scene_from_yaml(
      notch(1e-6, false, "{linear: umfpack}", "failure: {criterion: skew, G_c: 10.0, direction: [1, 0]}\n"));
  const Model model = discretise(scene);
  QuasiStaticProblem problem(model, problem_options(scene));
  problem.set_load_factor(1.0);
  VectorXd x = VectorXd::Zero(problem.n_unknowns());
  for (Index i = 0; i < x.size(); ++i) x[i] = 5e-5 * std::sin(1.7 * static_cast<double>(i));
  const BondFailure& failure = *problem.failure();
  const Index n = model.particles.size();
  std::vector<Index> before(n);
  for (Index i = 0; i < n; ++i) before[i] = failure.reference(i);
  ASSERT_EQ(problem.advance_irreversible_state(x, 200), 200);
  const auto first = failure.last_round();
  const double peak = failure.peak().ratio;
  Index replaced = 0;
  for (Index i = 0; i < n; ++i) {
    if (failure.reference(i) == before[i]) continue;
    ++replaced;
    const Index r = failure.reference(i);
    ASSERT_GE(r, 0);
    EXPECT_GT(failure.weights()[r], 0.0) << "particle " << i << " has a broken reference";
    EXPECT_EQ(failure.weights()[before[i]], 0.0) << "particle " << i << " lost an intact reference";
  }
  EXPECT_GT(replaced, 0);  // 200 of the most skewed bonds of a random state include references
  problem.revert_irreversible_state();
  for (Index i = 0; i < n; ++i) EXPECT_EQ(failure.reference(i), before[i]) << "particle " << i;
  ASSERT_EQ(problem.advance_irreversible_state(x, 200), 200);
  EXPECT_EQ(failure.last_round(), first);
  EXPECT_EQ(failure.peak().ratio, peak);
}

// The paper's case 4.4 (skew criterion, contact with f_c = 0.3 on old and new faces) at
// dx = 0.05 m, its first four steps (to 10 mm): Newton and ADR break the same bonds in
// every step, so the same particles carry the same damage at the end (26 bonds with the
// skew's floor, 141 with eq 22; the test does not pin the number, only that some broke), and the
// displacements agree to the solvers' tolerances (relative 1e-5: both converge to 1e-8 or
// better, the contact and friction states are the same).
TEST(Failure, NewtonAndAdrGrowTheSameCrackInCase44) {
  const std::vector<std::string> common{"discretization.spacing=0.05", "loading.steps=4",
                                        "boundary.2.uy=-10.0e-3"};
  std::vector<std::string> adr_set = common;
  adr_set.push_back("solver.type=adr");
  auto newton = test::solve_case("paper_4_4_crack_growth", common);
  auto adr = test::solve_case("paper_4_4_crack_growth", adr_set);
  ASSERT_TRUE(newton->run.completed && adr->run.completed) << adr->run.message;
  ASSERT_EQ(newton->steps.size(), adr->steps.size());
  for (std::size_t k = 0; k < newton->steps.size(); ++k)
    EXPECT_EQ(newton->steps[k].bonds_broken, adr->steps[k].bonds_broken) << "step " << k + 1;
  VectorXd dn, da;
  newton->problem->failure()->damage(dn);
  adr->problem->failure()->damage(da);
  const double du = (newton->u - adr->u).norm() / newton->u.norm();
  std::printf(
      "case 4.4 (dx 0.05, 10 mm): Newton broke %ld bonds, ADR %ld (%ld ADR iterations); max damage "
      "difference %.3e; relative displacement difference %.3e\n",
      static_cast<long>(newton->problem->failure()->broken()),
      static_cast<long>(adr->problem->failure()->broken()), adr->iterations(),
      (dn - da).cwiseAbs().maxCoeff(), du);
  EXPECT_GT(newton->problem->failure()->broken(), 0);
  EXPECT_EQ(newton->problem->failure()->broken(), adr->problem->failure()->broken());
  EXPECT_EQ((dn - da).cwiseAbs().maxCoeff(), 0.0);
  EXPECT_LT(du, 1e-5);
}

}  // namespace
}  // namespace peristat

namespace peristat {
namespace {

// Mode I, the load at which a crack starts to grow against Griffith. A centre crack of
// half-length a = 10 mm in a 100 x 100 mm plate (dx = 1 mm, m = 3) pulled at its top edge.
// The problem is linear (small kinematics), so one solve gives the pull at which the most
// stretched bond reaches s_c; the remote stress there (the reaction over W t) is compared
// with Griffith's sigma_c = sqrt(E G_c / (pi a)) times Feddersen's finite-width factor
// 1 / sqrt(sec(pi a / W)).
// Returns sigma_start / sigma_Griffith at spacing dx (horizon 3 dx).
double mode_i_ratio(double dx) {
  const double E = 1e9, nu = 0.3, G_c = 10.0, t = 1e-3, W = 0.1, a = 0.01, delta = 3 * dx;
  const std::string y = R"(name: griffith
materials:
  m: {E: 1.0e9, nu: 0.3, thickness: 1.0e-3, kinematics: small}
discretization: {spacing: )" +
                        std::to_string(dx) + R"(, horizon_factor: 3}
bodies:
  plate: {material: m, rectangle: {min: [0, 0], max: [0.1, 0.1]}}
cracks:
  - {from: [0.04, 0.05], to: [0.06, 0.05]}
boundary:
  - {body: plate, edge: bottom, uy: 0}
  - {body: plate, edge: top, uy: 1.0e-4}
  - {body: plate, region: {min: [0.0495, 0], max: [0.0505, 0.001]}, ux: 0}
solver: {linear: cg, newton: {rtol: 1.0e-12}}
)";
  auto s = test::solve_scene(y);
  EXPECT_TRUE(s->run.completed);
  const Model& m = s->model;
  double smax = 0.0;
  for (Index i = 0; i < m.particles.size(); ++i) {
    if (m.particles.fictitious[i]) continue;
    for (Index b = m.bonds.start[i]; b < m.bonds.start[i + 1]; ++b) {
      const Index j = m.bonds.neighbour[b];
      if (m.particles.fictitious[j]) continue;
      const Vec2 eta(s->u[2 * j] - s->u[2 * i], s->u[2 * j + 1] - s->u[2 * i + 1]);
      smax = std::max(smax, bond_stretch(m.xi(i, b), eta));
    }
  }
  double reaction = 0.0;
  const VectorXd& f = s->problem->internal_force();
  for (Index i = 0; i < m.particles.size(); ++i)
    if (m.particles.fictitious[i] && m.particles.position[i].y() > 0.05) reaction += f[2 * i + 1];
  const double mu = E / (2 * (1 + nu)), kappa = E / (2 * (1 - nu));
  const double sc = critical_stretch(G_c, kappa, mu, delta);
  const double sigma_pd = std::abs(reaction) / (W * t) * sc / smax;
  const double sigma_griffith = std::sqrt(E * G_c / (M_PI * a)) / std::sqrt(1.0 / std::cos(M_PI * a / W));
  std::printf("mode I, dx = %.2g mm: s_c = %.4e, start stress %.4e Pa, Griffith %.4e Pa, ratio %.3f\n",
              dx * 1e3, sc, sigma_pd, sigma_griffith, sigma_pd / sigma_griffith);
  return sigma_pd / sigma_griffith;
}

// Mode I, the load at which a crack starts to grow, against Griffith. A centre crack of
// half-length a = 10 mm in a 100 x 100 mm plate, m = 3, pulled at its top edge. The problem
// is linear (small kinematics), so one solve gives the pull at which the most stretched
// bond reaches s_c; the remote stress there (the reaction over W t) is compared with
// Griffith's sigma_c = sqrt(E G_c / (pi a)) times Feddersen's finite-width factor
// 1 / sqrt(sec(pi a / W)). Tolerance 15%: the first broken bond is a nonlocal estimate of
// the start of growth, and s_c comes from an energy argument, not from the crack-tip field.
// Measured with the surface correction (the default since issue 13; it checks the critical
// stretch formula against the corrected model): 1.027 at dx = 1 mm and 1.040 at 0.5 mm
// (delta / a = 0.3 and 0.15); uncorrected 1.089 and 1.098. The estimate does not drift
// with resolution at fixed m; asserted: within 2% of each other.
TEST(Failure, ModeIStartLoadAgainstGriffith) {
  const double coarse = mode_i_ratio(1e-3), fine = mode_i_ratio(5e-4);
  EXPECT_NEAR(coarse, 1.0, 0.15);
  EXPECT_NEAR(fine, 1.0, 0.15);
  EXPECT_NEAR(fine / coarse, 1.0, 0.02);
}

}  // namespace
}  // namespace peristat
