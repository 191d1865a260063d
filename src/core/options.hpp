// The typed options of each component (STYLE.md, "one typed options struct per component").
// scene/ converts YAML into them and checks every range; the components take only their
// own struct, so solvers/, assembly/, materials/ and contact/ never see the Scene.
// docs/guide/scene.md documents every key.
#pragma once

#include <string>
#include <string_view>
#include <vector>

#include "core/error.hpp"
#include "core/types.hpp"

namespace peristat {

// ---- solvers ---------------------------------------------------------------------------

/// solver.type: the nonlinear solver of every load step.
enum class SolverKind { newton, adr };

/// The tangent Newton factorises (solver.newton.tangent).
enum class TangentKind {
  consistent,  ///< the exact Jacobian at every iterate
  initial      ///< the first tangent of the run, factorised once
};

/// Newton's method (solver.newton.*, docs/theory/newton.md).
struct NewtonOptions {
  double rtol = 1e-10;  ///< relative residual ||r_free|| / ||f_int|| (docs/theory/newton.md)
  /// Absolute residual floor [N]; below 0 (the default): 1e-14 E t dx of the stiffest
  /// material, resolved by the scene parser (a fixed floor in newtons would stop a soft body's
  /// solve before it starts).
  double atol = -1.0;
  double stol = 0.0;    ///< increment tolerance ||du|| / ||u||; 0 = not used
  int max_iterations = 25;
  bool line_search = true;  ///< backtracking on the residual norm
  int line_search_max = 8;
  TangentKind tangent = TangentKind::consistent;  ///< initial: factorise once per run
  /// solver.newton.forcing: true (`adaptive`, the default) lets a Krylov linear solver stop at
  /// the Eisenstat-Walker forcing term (docs/theory/newton.md, "Inexact Newton"); false
  /// (`fixed`): every solve to solver.krylov.rtol. Direct solvers are exact either way.
  bool adaptive_forcing = true;
};

/// Adaptive Dynamic Relaxation (solver.adr.*, docs/theory/adr.md).
struct AdrOptions {
  double rtol = 1e-8;             ///< relative residual, the same measure as newton.rtol
  long max_iterations = 100000;   ///< pseudo-time steps per load (sub)step
  bool accept_on_budget = false;  ///< on_budget: accept keeps an unconverged state (the paper's fixed count)
  double density_factor = 1.0;    ///< fictitious density = factor * 1/4 * sum_j |K_ij| (>= 1 is stable)
  long report_every = 1000;       ///< progress line and residual sample interval [iterations]
  /// breaking: iterations. Bonds over the failure criterion break at every pseudo-time step,
  /// not between converged equilibria, as explicit codes do (docs/theory/adr.md, "Breaking
  /// during the iterations"); the load stepping then does no re-solves.
  bool break_during = false;
};

/// solver.linear: the linear solver behind Newton.
/// solver.linear. `automatic` is the key's value `auto` (the default): the program picks one
/// of the others from the model's size, its physics and the ranks (choose_linear_solver in
/// src/app/run_plan.hpp) before anything is built.
/// `matrix_free`: CG/GMRES on the exact tangent action, never assembled, preconditioned by the
/// bond factor (docs/theory/newton.md, "Matrix-free").
enum class LinearSolverKind { cholmod, umfpack, klu, ldlt, cg, bicgstab, belos, matrix_free, automatic };

/// solver.krylov.preconditioner. `automatic` is the key's value `auto`: bond with cg,
/// bond_amg with matrix_free, ilut with bicgstab.
/// bond_amg: a MueLu V-cycle of the bond matrix instead of its factor (cg, matrix_free).
enum class PreconditionerKind { automatic, bond, cholmod, ic, diagonal, ilut, bond_amg };

/// solver.krylov.factors: how the matrix-free action keeps the families' per-bond factors
/// (s_b and the pair stiffness, assembly/tangent_action.hpp). `automatic` (the key's value
/// `auto`): single precision on the largest models without a failure criterion
/// (RunPlan::float_factors); with frictional contact (GMRES) double with a single-precision
/// copy for the Krylov iterations (`mixed`, RunPlan::float_copy); double otherwise.
enum class ActionFactors { automatic, double_precision, single_precision, mixed };

/// solver.belos.method: Belos's Krylov method. `automatic` (the key's value `auto`): CG while
/// the tangent is symmetric, GMRES while contact pairs slip.
enum class BelosMethod { automatic, cg, gmres };

/// solver.belos.preconditioner (docs/guide/distributed.md).
enum class BelosPreconditioner {
  muelu,               ///< MueLu smoothed aggregation, 2 unknowns per particle, rigid-body modes
  ifpack2_ilut,        ///< Ifpack2 ILUT on each rank's block (additive Schwarz)
  ifpack2_relaxation,  ///< Ifpack2 symmetric Gauss-Seidel on each rank's block
  bond_factor          ///< CHOLMOD factor of each rank's block of the bond matrix (additive Schwarz)
};

/// solver.belos.partition: which rows each MPI rank owns (docs/guide/distributed.md).
enum class BelosPartition {
  strips,  ///< the lattice in P slabs across x, each with an equal count of particles with an unknown
  rcb      ///< the lattice bisected recursively across its longer extent, equal counts (LatticePartition)
};

/// solver.belos.tangent: how Belos applies the tangent (docs/guide/distributed.md).
enum class BelosTangent {
  assembled,   ///< each rank's rows of the assembled two-horizon matrix, copied into Tpetra
  matrix_free  ///< the problem's apply_tangent() on each rank's rows; only the bond matrix assembled
};

/// The Trilinos path (solver.linear: belos; solver.belos.*).
struct BelosOptions {
  BelosMethod method = BelosMethod::automatic;
  /// muelu with a matrix-free tangent: the fastest pair, and the smallest, on every scene
  /// measured on two ranks (docs/guide/distributed.md, "Matrix-free tangent").
  BelosPreconditioner preconditioner = BelosPreconditioner::muelu;
  /// rcb: equal or fewer Krylov iterations than strips on every case measured on two ranks
  /// (case 4.1: 200 against 693, docs/guide/distributed.md "Partition").
  BelosPartition partition = BelosPartition::rcb;
  BelosTangent tangent = BelosTangent::matrix_free;
  double rtol = 1e-10;        ///< relative residual ||b - A x|| / ||b||
  int max_iterations = 2000;  ///< Krylov iterations per solve
  int restart = 100;          ///< GMRES basis vectors before a restart
  /// A MueLu XML parameter list that replaces peristat's own (solver.belos.muelu_parameters;
  /// empty: peristat's). Checked for readability by the parser, parsed by the solver.
  std::string muelu_parameters;
};

/// Linear solver (key solver.linear) and its iterative settings (solver.krylov.*).
struct LinearOptions {
  LinearSolverKind type = LinearSolverKind::automatic;
  double rtol = 1e-10;        ///< Krylov relative residual
  int max_iterations = 2000;  ///< Krylov iteration cap
  /// auto | bond | cholmod | ic | diagonal (cg); auto | ilut | diagonal (bicgstab)
  PreconditionerKind preconditioner = PreconditionerKind::automatic;
  BelosOptions belos;  ///< solver.belos.* (used when type is belos)
  /// When the scene said `auto`: what it resolved to and why (summary.json run.solver.linear_auto).
  std::string auto_choice;
};

/// The `bond` preconditioner matrix the problem assembles (solver.krylov.bond_radius):
/// bonds of length <= bond_radius * dx, >= 1 (default 2.25: the 20 nearest lattice
/// neighbours; docs/theory/newton.md, "Bond preconditioner").
struct BondPreconditionerOptions {
  double bond_radius = 2.25;
  /// solver.krylov.contact_zone: rings of the stencil around the contact pairs' particles
  /// whose current rows of P GMRES solves exactly after each V-cycle (0: none;
  /// docs/theory/newton.md, "The contact zone's exact correction").
  int contact_zone_layers = 3;
  /// solver.krylov.contact_zone_cap: the zone stops growing past this fraction of the
  /// particles, and is not used when the contact particles alone pass it.
  double contact_zone_cap = 0.2;
  bool radius_given = false;  ///< the scene set it (solver.linear: auto then leaves it alone)
};

/// Load stepping (loading.*).
struct Loading {
  int steps = 1;           ///< equal load steps to load factor 1, >= 1
  int max_cutbacks = 6;    ///< halvings of a failing step before giving up, >= 0
  /// Re-solves at one load after irreversible changes before the run stops (exit 3); 0: no
  /// limit (the default: every converged round breaks at least one bond for good, so a
  /// running crack ends when it arrests or the body separates).
  int max_resolves = 0;
  /// loading.predictor: the first iterate of a load (sub)step. true (`extrapolate`, the
  /// default): the unknowns extrapolated linearly in the load factor from the last two
  /// accepted states; false (`previous`): the last accepted state.
  bool extrapolate = true;
};

/// The names the scene uses (for messages and summary.json).
std::string_view to_string(SolverKind kind);
std::string_view to_string(LinearSolverKind kind);
std::string_view to_string(PreconditionerKind kind);
std::string_view to_string(ActionFactors kind);
std::string_view to_string(BelosMethod kind);
std::string_view to_string(BelosPreconditioner kind);
std::string_view to_string(BelosPartition kind);
std::string_view to_string(BelosTangent kind);

// ---- physics ---------------------------------------------------------------------------

/// Bond failure (key `failure:`; docs/theory/failure.md). Absent: no failure checks at all.
enum class FailureCriterion { stretch, skew };
struct FailureOptions {
  bool enabled = false;
  FailureCriterion criterion = FailureCriterion::stretch;
  double G_c = 0.0;               ///< critical energy release rate [J/m^2], > 0
  Vec2 direction = Vec2::Zero();  ///< skew: reference direction (non-zero)
  /// skew: bonds within this angle [degrees] of the reference have their offset across it
  /// floored at |xi| sin(angle) (docs/theory/failure.md, "The skew of shallow bonds");
  /// 0 is the paper's eq 22. [0, 90).
  double skew_min_angle = 45.0;
  /// skew: the critical skew is eq 19's times this factor (docs/theory/failure.md, "A
  /// boundary-layer calibration"); 1 is the paper's energy calibration. > 0.
  double skew_scale = 1.0;
  double fraction = 1.0;  ///< break this most critical fraction of the bonds over the criterion, (0, 1]
  SourceLocation where;
};

/// How the normal contact force of a candidate pair is computed (docs/theory/contact.md).
///  - paper: eqs 15-17 of Lu et al., p_c = E_c (|X.n| - |Y.n|) / |X.n| along the declared
///    interface or crack normal n, active while |Y| < delta_c.
///  - pair: a short-range repulsion along the current pair direction,
///    F = C (delta_c - |Y|) / delta_c, zero at |Y| = delta_c (smooth switch-on).
enum class NormalLaw { paper, pair };

/// How non-penetration is enforced (docs/theory/contact.md, sections 2 and 8).
///  - penalty: the normal law alone; the closure of a pair depends on the contact stiffness.
///  - exact: an augmented Lagrangian. Each facing pair carries a multiplier; the load step is
///    solved again with updated multipliers until every active pair's closure is below
///    closure_tolerance, whatever the stiffness (which then only sets the convergence rate).
enum class ContactEnforcement { penalty, exact };

/// Exact enforcement: what a pair's closure counts from (docs/theory/contact.md, "The
/// closure's reference"): its reference normal distance a (`spacing`), or a shortened by the
/// material's own compressive normal strain at the pair, for the faces of broken bonds only
/// (`broken_bonds`, the default) or for every pair (`material`).
enum class ClosureReference { spacing, broken_bonds, material };

/// Two bodies declared in contact. They must share a boundary segment (the interface).
struct ContactInterface {
  std::string body_a, body_b;
  SourceLocation where;
};

/// contact.closure_tolerance when the scene gives none and declares no failure criterion.
inline constexpr double kDefaultClosureTolerance = 1e-3;
/// With a failure criterion, the tolerance not given is at most this fraction of the critical
/// stretch s_c: a closed crack's faces that may overlap by more than its bonds stretch before
/// they break move the load at which the criterion starts a crack (docs/theory/contact.md,
/// "The tolerance against a failure criterion": at 0.1 s_c a start moved by 1 %, which the
/// default halves).
inline constexpr double kClosureToleranceOverStretch = 0.05;
/// A tolerance the scene gives above this fraction of s_c, with a criterion, is warned about.
inline constexpr double kClosureToleranceWarnOverStretch = 0.1;

/// Contact between broken-bond pairs (pre-cracks) and across declared body interfaces.
/// Absent section or enabled: false = no contact: no candidates, no cost.
struct ContactOptions {
  bool enabled = false;        ///< true when a `contact:` section is present, unless it says false
  double friction = 0.0;       ///< Coulomb coefficient f_c >= 0; 0 builds no friction state
  double radius_factor = 1.0;  ///< delta_c = radius_factor * dx, > 0
  NormalLaw normal = NormalLaw::paper;
  /// Contact modulus E_c [Pa]; 0 = from eq 17 with the two materials' E and nu.
  double stiffness = 0.0;
  /// Tangential (stick) penalty as a multiple of the normal pair stiffness, > 0.
  double tangential_factor = 1.0;
  /// Width of the switch-on ramp of the paper law as a fraction of delta_c, in [0, 1):
  /// the force rises linearly from 0 at |Y| = delta_c to full at (1 - gate) delta_c, so no
  /// pair switches on with a jump. 0 is the paper's sharp gate.
  double gate = 0.1;
  bool cracks = true;  ///< pre-crack faces are contact candidates
  std::vector<ContactInterface> interfaces;
  /// friction_law: return_map (default; Newton and ADR) or velocity_sign (the paper's eq 13:
  /// f_c F_n against the sign of the pseudo-velocity; ADR only).
  bool velocity_sign = false;
  /// exact by default (the continuum's non-penetration); penalty under `normal: pair`, which
  /// has no normal to enforce, and where the scene says so (the paper's law).
  ContactEnforcement enforcement = ContactEnforcement::exact;
  /// exact enforcement with friction: stick is a multiplier too (true, the default), or the
  /// penalty k_t = tangential_factor C / a (`stick: penalty`).
  bool exact_stick = true;
  /// exact: largest accepted closure (a - n.Y) / a of a pair in contact, in (0, 1). When the
  /// scene does not give it: kDefaultClosureTolerance, or kClosureToleranceOverStretch times
  /// the smallest critical stretch when a failure criterion is declared and that is smaller
  /// (resolve_run_plan() writes it here, and why into closure_tolerance_auto).
  double closure_tolerance = kDefaultClosureTolerance;
  bool closure_tolerance_given = false;  ///< the scene or --set gave closure_tolerance
  std::string closure_tolerance_auto;    ///< why the tolerance not given is what it is; "" when given
  /// exact: multiplier updates allowed per load increment before the attempt counts as failed.
  int max_multiplier_updates = 30;
  /// exact: what a pair's closure counts from (ClosureReference).
  ClosureReference closure_reference = ClosureReference::broken_bonds;
  SourceLocation closure_reference_where;
  SourceLocation friction_law_where;
  SourceLocation enforcement_where;
  SourceLocation stick_where;
  SourceLocation where;
};

std::string_view to_string(ContactEnforcement kind);
std::string_view to_string(ClosureReference kind);

}  // namespace peristat
