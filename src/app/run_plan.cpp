#include "app/run_plan.hpp"

#include <algorithm>
#include <cstdio>
#include <limits>

#include "app/preflight.hpp"
#include "materials/failure.hpp"
#include "materials/osb.hpp"

namespace peristat {

namespace {

/// Newton applies the tangent's action with matrix_free, and with belos on its matrix-free
/// tangent (solver.belos.tangent); every other linear solver, and ADR, assembles it.
TangentForm tangent_form(const Scene& scene, LinearSolverKind linear) {
  const bool action = scene.solver.type == SolverKind::newton &&
                      (linear == LinearSolverKind::matrix_free ||
                       (linear == LinearSolverKind::belos &&
                        scene.solver.linear.belos.tangent == BelosTangent::matrix_free));
  return action ? TangentForm::matrix_free : TangentForm::assembled;
}

/// solver.krylov.preconditioner's `auto` as make_linear_solver() resolves it.
PreconditionerKind resolved_preconditioner(PreconditionerKind asked, LinearSolverKind linear) {
  if (asked != PreconditionerKind::automatic) return asked;
  if (linear == LinearSolverKind::bicgstab) return PreconditionerKind::ilut;
  return linear == LinearSolverKind::matrix_free ? PreconditionerKind::bond_amg : PreconditionerKind::bond;
}

/// Under mpirun every rank holds its own part of the model and the rings of families around it
/// (part_rings()); one process's part is the whole model.
ModelChoice model_choice(const Scene& scene, const RunPlan& plan) {
  if (plan.ranks <= 1) return {0, "one process: the whole model, one part"};
  const int rings = part_rings(plan);
  std::string reason = rings == 1 ? "each rank holds its own particles, the families of their neighbours, and "
                                    "vectors over their unknowns only"
                                  : "each rank holds its own particles, the families of two rings around "
                                    "them (an assembled tangent), and vectors over their unknowns only";
  if (scene.contact.enabled) reason += "; the parts grow when the contact faces slide past them";
  return {rings, reason};
}

/// `auto` shortens the bond preconditioner's radius of a matrix-free tangent on large models;
/// returns what it says of it ("" when the radius stays). `friction`: the scene's contact
/// pairs may slip (GMRES, many solves per set-up).
std::string shorten_bond_radius(RunPlan& plan, double unknowns, bool friction) {
  BondPreconditionerOptions& bond = plan.bond_preconditioner;
  if (!plan.matrix_free() || bond.radius_given) return {};
  // Without friction a shorter radius makes the bond matrix sparser and its V-cycle cheaper
  // for about the same iterations; with friction the 20 neighbours' stronger V-cycle serves
  // every Newton iteration and re-solve of the run, up to kFrictionShortBondsAbove, where
  // memory decides (run_plan.hpp, kMediumBondsAbove).
  const double radius = friction ? (unknowns > kFrictionShortBondsAbove ? 1.42 : bond.bond_radius)
                                 : (unknowns > kMediumBondsAbove ? 2.0 : bond.bond_radius);
  if (radius == bond.bond_radius) return {};
  char buf[120];
  std::snprintf(buf, sizeof buf, "; bond preconditioner radius %.3g dx for this size", radius);
  bond.bond_radius = radius;
  return buf;
}

bool picks_linear_solver(const Scene& scene) {
  return scene.solver.type == SolverKind::newton && scene.solver.linear.type == LinearSolverKind::automatic;
}

/// solver.krylov.factors `auto` on `plan`: float on a matrix-free tangent above
/// kFloatFactorsAbove unknowns without a failure criterion (then plan.factors_auto says why).
void resolve_action_factors(const Scene& scene, RunPlan& plan, double unknowns) {
  if (scene.solver.action_factors != ActionFactors::automatic) return;  // plan_with_linear() took it
  plan.float_factors = plan.matrix_free() && unknowns > kFloatFactorsAbove && !scene.failure.enabled;
  // GMRES (slipping pairs) on the double factors' float copy: case 4.4 at dx = 0.01 m, 4.9
  // against 5.2 ms an action and 1,260 against 1,282 Krylov iterations; CG (the running crack)
  // took 6 % more iterations on it (docs/performance.md, "Mixed factors").
  plan.float_copy =
      !plan.float_factors && plan.matrix_free() && scene.contact.enabled && scene.contact.friction > 0.0;
  if (plan.float_copy) {
    plan.factors_auto =
        "mixed: frictional contact (GMRES): the Krylov iterations read a float copy of the double "
        "factors, 16 more bytes per bond";
    return;
  }
  if (!plan.float_factors) return;
  char buf[200];
  std::snprintf(buf, sizeof buf,
                "float: about %.0f unknowns > %.0f and no failure criterion: the action's factors take 16 "
                "bytes per bond instead of 32",
                unknowns, kFloatFactorsAbove);
  plan.factors_auto = buf;
}

/// The scene's `auto` choices read the size: the unknowns estimated before discretising, or 0
/// when nothing is left to pick.
bool needs_size(const Scene& scene) {
  return picks_linear_solver(scene) ||
         (scene.solver.type == SolverKind::newton && scene.solver.action_factors == ActionFactors::automatic);
}

}  // namespace

LinearChoice choose_linear_solver(const Scene& scene, double unknowns, int ranks) {
  char buf[200];
  if (ranks > 1) {
    std::snprintf(buf, sizeof buf, "%d MPI ranks: only belos distributes the solves", ranks);
    return {LinearSolverKind::belos, buf};
  }
  if (scene.contact.enabled && scene.contact.friction > 0.0)
    return {LinearSolverKind::matrix_free,
            "friction: slipping pairs make the tangent unsymmetric, where GMRES beats UMFPACK (case 4.3 at "
            "5,000 unknowns: 1.0 s against 2.7 s), the tangent's action beats assembling it (case 4.1: 7.3 s "
            "against 10.8 s) and a MueLu V-cycle of the bond matrix beats its factor (4.3 s against 6.4 s)"};
  if (unknowns <= kDirectMaxUnknowns) {
    std::snprintf(buf, sizeof buf, "about %.0f unknowns <= %.0f: a direct factor is as fast and needs no Krylov tolerance",
                  unknowns, kDirectMaxUnknowns);
    return {LinearSolverKind::cholmod, buf};
  }
  std::snprintf(buf, sizeof buf,
                "about %.0f unknowns > %.0f: CG with the tangent's action, preconditioned by a MueLu V-cycle "
                "of the bond matrix, is faster and smaller than a factor of the tangent or an assembled tangent",
                unknowns, kDirectMaxUnknowns);
  return {LinearSolverKind::matrix_free, buf};
}

int part_rings(const RunPlan& plan) {
  // The matrix-free tangent reads the families one stencil around the rows; the assembled
  // tangent's columns (Newton's, or ADR's for its density) reach two.
  return plan.matrix_free() ? 1 : 2;
}

RunPlan plan_with_linear(const Scene& scene, int ranks, LinearSolverKind linear) {
  RunPlan plan;
  plan.ranks = ranks;
  plan.solver = scene.solver.type;
  plan.linear = linear;
  plan.tangent = tangent_form(scene, linear);
  plan.preconditioner = resolved_preconditioner(scene.solver.linear.preconditioner, linear);
  plan.bond_preconditioner = scene.solver.bond_preconditioner;
  // An explicit `float` without the action has nothing to store (preflight() refuses it);
  // `auto` is make_run_plan()'s.
  plan.float_factors = scene.solver.action_factors == ActionFactors::single_precision && plan.matrix_free();
  plan.float_copy = scene.solver.action_factors == ActionFactors::mixed && plan.matrix_free();
  plan.model = model_choice(scene, plan);
  return plan;
}

RunPlan scene_plan(const Scene& scene, int ranks) {
  RunPlan plan = plan_with_linear(scene, ranks, scene.solver.linear.type);
  plan.linear_auto = scene.solver.linear.auto_choice;  // of a scene resolved before
  return plan;
}

RunPlan make_run_plan(const Scene& scene, int ranks, double unknowns) {
  RunPlan plan;
  if (picks_linear_solver(scene)) {
    const LinearChoice choice = choose_linear_solver(scene, unknowns, ranks);
    plan = plan_with_linear(scene, ranks, choice.kind);
    plan.linear_auto =
        std::string(to_string(choice.kind)) + ": " + choice.reason +
        shorten_bond_radius(plan, unknowns, scene.contact.enabled && scene.contact.friction > 0.0);
  } else {
    plan = scene_plan(scene, ranks);
  }
  resolve_action_factors(scene, plan, unknowns);
  return plan;
}

RunPlan make_run_plan(const Scene& scene, int ranks) {
  return make_run_plan(scene, ranks, needs_size(scene) ? estimated_unknowns(estimate_model(scene)) : 0.0);
}

double smallest_critical_stretch(const Scene& scene) {
  const double delta = scene.discretization.horizon_factor * scene.discretization.spacing;
  double s_c = std::numeric_limits<double>::infinity();
  for (const Body& b : scene.bodies) {
    const auto m = scene.materials.find(b.material);
    if (m == scene.materials.end()) continue;
    s_c = std::min(s_c, critical_stretch(scene.failure.G_c, bulk_modulus_2d(m->second),
                                         shear_modulus(m->second), delta));
  }
  return s_c;
}

void resolve_closure_tolerance(Scene& scene) {
  ContactOptions& c = scene.contact;
  if (c.closure_tolerance_given) {
    c.closure_tolerance_auto.clear();
    return;
  }
  c.closure_tolerance = kDefaultClosureTolerance;
  char buf[200];
  std::snprintf(buf, sizeof buf, "%g, the default without a failure criterion", kDefaultClosureTolerance);
  if (scene.failure.enabled) {
    const double s_c = smallest_critical_stretch(scene);
    if (kClosureToleranceOverStretch * s_c < kDefaultClosureTolerance) {
      c.closure_tolerance = kClosureToleranceOverStretch * s_c;
      std::snprintf(buf, sizeof buf,
                    "%.3g, %g of the critical stretch %.3g (a failure criterion is declared)",
                    c.closure_tolerance, kClosureToleranceOverStretch, s_c);
    } else {
      std::snprintf(buf, sizeof buf, "%g, the default (below %g of the critical stretch %.3g)",
                    kDefaultClosureTolerance, kClosureToleranceOverStretch, s_c);
    }
  }
  c.closure_tolerance_auto = buf;
}

RunPlan resolve_run_plan(Scene& scene, int ranks) {
  resolve_closure_tolerance(scene);
  const RunPlan plan = make_run_plan(scene, ranks);
  if (picks_linear_solver(scene)) {
    scene.solver.linear.type = plan.linear;
    scene.solver.linear.auto_choice = plan.linear_auto;
    scene.solver.bond_preconditioner = plan.bond_preconditioner;
  }
  if (scene.solver.action_factors == ActionFactors::automatic && plan.newton())
    scene.solver.action_factors = plan.float_factors ? ActionFactors::single_precision
                                  : plan.float_copy  ? ActionFactors::mixed
                                                     : ActionFactors::double_precision;
  return plan;
}

std::string resolve_linear_solver(Scene& scene, int ranks) {
  const bool picks = picks_linear_solver(scene);
  const RunPlan plan = resolve_run_plan(scene, ranks);
  return picks ? plan.linear_auto : std::string();
}

}  // namespace peristat
