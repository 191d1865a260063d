// The run plan: every choice a run makes from its scene and its ranks, resolved once
// (solver.linear `auto`, the tangent's form, the preconditioner, the model a rank holds and the
// rings of families around it). `run` and `check` make it first; the preflight, the model
// builder and the setup (problem_options, make_step_solver) read it instead of deriving the
// choices again.
#pragma once

#include <string>

#include "scene/scene.hpp"

namespace peristat {

/// What `solver.linear: auto` picked, and why (printed by run and check, in summary.json).
struct LinearChoice {
  LinearSolverKind kind = LinearSolverKind::cg;
  std::string reason;
};

/// Models with at most this many unknowns and no friction get a direct factor (CHOLMOD):
/// whole runs of the tension plate, best of two, 2 cores: 1,249 unknowns 0.19 s against cg's
/// 0.28 s, 3,196 0.48 against 0.41 s, 4,994 0.59 against 0.57 s, 19,970 3.2 against 2.2 s
/// (docs/performance.md, "solver.linear: auto"); below the crossover a factor is also exact.
inline constexpr double kDirectMaxUnknowns = 2500.0;
/// With matrix_free, `auto` shortens the bond preconditioner's radius (unless the scene sets
/// solver.krylov.bond_radius) to 2.0 dx above kMediumBondsAbove unknowns without friction;
/// with friction (contact.friction > 0) it keeps 2.25 dx, its stronger V-cycle serving every
/// Newton iteration and re-solve, up to kFrictionShortBondsAbove unknowns, and 1.42 dx above,
/// for memory (docs/performance.md, "Matrix-free"). Runs in turn, 2026-12-04 and -05:
/// - with friction, 2.0 against 2.25 dx: case 4.4 at dx = 0.01 m (160,600 unknowns) 52.8 /
///   46.6 against 36.9 / 34.0 s (2,817 against 1,769 Krylov iterations, the same bonds broken
///   in every step); case 4.1 at dx = 2.5e-4 m 5.20 / 5.53 against 4.90 / 4.99 s; case 4.3 at
///   dx = 0.004 m 4.63 / 4.74 against 4.31 / 4.26 s; 18 % more memory. 1.42 against 2.25 dx on
///   case 4.1 at dx = 1.2e-4 m (537,599 unknowns): 34.6 against 32.1 s, 0.96 against 1.35 GB;
///   kept for memory, since the 20-neighbour V-cycle (about 2.7 KB per unknown at 65 bytes
///   per bond-matrix nonzero) would refuse frictional models of a few million unknowns that
///   fit at 1.42 dx.
/// - without friction 2.25 gains nothing (125,000 unknowns: lefm_inclined_crack 7.9 against
///   8.4 s, mixed_mode_crack 414 against 411 s), and 2.0 beats 1.42 dx on the 1000 x 1000
///   plate: 45.6 against 52.6 s (175 against 260 Krylov iterations), 2.91 against 2.75 GB.
inline constexpr double kMediumBondsAbove = 100000.0;
inline constexpr double kFrictionShortBondsAbove = 500000.0;
/// solver.krylov.factors `auto` keeps the matrix-free action's per-bond factors in single
/// precision (16 bytes per directed bond instead of 32) above this many unknowns, when the
/// scene has no failure criterion. Measured
/// in docs/performance.md ("Single-precision factors"): on the 1000 x 1000 plate the same
/// Newton and Krylov iterations and answers within the Newton tolerance, 0.7 GB less; on
/// cracked scenes whose ligaments thin as bonds break (the running crack) the iterations grew,
/// so scenes with a failure criterion keep double.
inline constexpr double kFloatFactorsAbove = 500000.0;

/// The linear solver `solver.linear: auto` stands for, from the number of unknowns (an
/// estimate before discretising, or the model's), the scene's physics and the MPI ranks:
/// belos under mpirun; else CHOLMOD for small models without friction; else matrix_free
/// (CG on the bond factor, GMRES while pairs slip, with the tangent's action: faster and
/// smaller than the assembled cg path on every case measured). docs/performance.md.
LinearChoice choose_linear_solver(const Scene& scene, double unknowns, int ranks);

/// What a rank holds of the model, and why. Every rank holds its part: under mpirun its own
/// particles, and the families of one ring of particles around them for Newton's matrix-free
/// tangent, two for an assembled tangent (belos's `assembled`, or ADR's for its density);
/// docs/guide/distributed.md. One process's part is the whole model.
struct ModelChoice {
  int rings = 0;  ///< under mpirun: stencils around a part's particles whose families it holds
  std::string reason;
};

/// How Newton applies the tangent: assembled into a sparse matrix, or as its action
/// (solver.linear matrix_free, or belos with solver.belos.tangent matrix_free; no pattern is
/// built, ProblemOptions::matrix_free). ADR's tangent is assembled (its density reads it).
enum class TangentForm { assembled, matrix_free };

struct RunPlan {
  int ranks = 1;  ///< MPI ranks of the run
  SolverKind solver = SolverKind::newton;
  /// Newton's linear solver, `auto` resolved by make_run_plan() (scene_plan() leaves it);
  /// ADR's is the scene's, unused.
  LinearSolverKind linear = LinearSolverKind::automatic;
  std::string linear_auto;  ///< what `auto` picked and why; "" when the scene named one, or ADR
  TangentForm tangent = TangentForm::assembled;
  /// solver.krylov.preconditioner with `auto` resolved as make_linear_solver() does (bond with
  /// cg, bond_amg with matrix_free, ilut with bicgstab).
  PreconditionerKind preconditioner = PreconditionerKind::automatic;
  /// The bond preconditioner's radius, shortened by `auto` on large matrix-free models.
  BondPreconditionerOptions bond_preconditioner;
  /// The matrix-free action keeps its per-bond factors in single precision
  /// (solver.krylov.factors; `auto` resolved by make_run_plan(): kFloatFactorsAbove).
  bool float_factors = false;
  /// Double factors with a single-precision copy that the Krylov iterations read
  /// (solver.krylov.factors mixed; `auto` with frictional contact, make_run_plan()).
  bool float_copy = false;
  std::string factors_auto;  ///< what `auto` picked for the factors and why, when it picked float
  ModelChoice model;  ///< the rank's part of the model and its rings, or the whole model

  bool newton() const { return solver == SolverKind::newton; }
  bool matrix_free() const { return tangent == TangentForm::matrix_free; }
};

/// The plan of a run of `scene` on `ranks` ranks: `auto` picked for the unknowns estimated
/// before discretising (estimate_model()). The scene is not changed.
RunPlan make_run_plan(const Scene& scene, int ranks);
/// The same with `auto` picked for `unknowns`.
RunPlan make_run_plan(const Scene& scene, int ranks, double unknowns);
/// The plan the scene states, `auto` left unresolved (an assembled tangent): for callers that
/// build the objects from a scene without planning a run (tests, benchmarks).
RunPlan scene_plan(const Scene& scene, int ranks);
/// The plan the scene states with `linear` as Newton's linear solver (no `auto` reason).
RunPlan plan_with_linear(const Scene& scene, int ranks, LinearSolverKind linear);

/// The rings of families around its particles a rank's part holds under `plan`: one for
/// Newton's matrix-free tangent, two for an assembled tangent (belos's `assembled`, or ADR's
/// for its density).
int part_rings(const RunPlan& plan);

/// The smallest critical stretch of the scene's bodies under its failure.G_c (the critical
/// stretch's, whatever the criterion): +infinity without a body.
double smallest_critical_stretch(const Scene& scene);

/// contact.closure_tolerance when the scene does not give it: kDefaultClosureTolerance, or
/// kClosureToleranceOverStretch x smallest_critical_stretch() when a failure criterion is
/// declared and that is smaller. Written into the scene with its reason
/// (contact.closure_tolerance_auto); a tolerance the scene gives is kept.
void resolve_closure_tolerance(Scene& scene);

/// make_run_plan(), with its picks written into the scene (solver.linear.type, its
/// auto_choice and the bond radius) and the closure tolerance resolved
/// (resolve_closure_tolerance()), so that the record states what ran: what `run` and `check`
/// do first.
RunPlan resolve_run_plan(Scene& scene, int ranks);
/// resolve_run_plan()'s `auto` pick and reason, or "" when the scene named a solver (an
/// explicit choice always wins) or runs ADR.
std::string resolve_linear_solver(Scene& scene, int ranks);

}  // namespace peristat
