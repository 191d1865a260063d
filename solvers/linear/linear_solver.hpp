// The linear-solver seam. Method names follow Eigen (analyzePattern, factorize, solve,
// info) so Eigen's and SuiteSparse's solvers fit behind it. The solvers of heavier libraries
// (belos, the bond_amg V-cycle) are makers that the program registers (register_linear_solver,
// register_preconditioner): nothing here includes or links them.
// Nothing here knows about physics.
#pragma once

#include <cstdint>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/SparseCore>

#include "core/options.hpp"
#include "core/types.hpp"

namespace peristat {

/// What the unknowns are, for solvers that build their own hierarchy or partition (belos
/// with muelu groups the two directions of a particle and uses the rigid-body modes):
/// component[k] = 2 p + d for unknown k (particle p, direction d), and every particle's
/// reference position. Nothing about physics beyond that.
struct UnknownLayout {
  std::vector<Index> component;  ///< per unknown: 2 * particle + direction
  std::vector<double> x, y;      ///< per particle [m]
  /// Per particle, the MPI rank that owns its rows (the assembly's OwnedRows::owner); empty:
  /// strips of the particles in their order (one process: every row).
  std::vector<int> owner;
  /// A rank's part of the model (ModelPart, docs/guide/distributed.md "The partitioned model"):
  /// per particle of the part, the global number of its node (the particles that have an
  /// unknown, numbered rank by rank, each rank's in the whole model's order), -1 for a particle
  /// without an unknown; `owner` is then required. Empty: every rank holds the whole model.
  std::vector<std::int64_t> global_node;
  std::int64_t global_nodes = 0;  ///< with global_node: the nodes of every rank
  std::int64_t first_node = 0;    ///< with global_node: this rank's first node
  /// The centre of the rigid-body rotation mode; NaN: the mean of x and y (a part's layout
  /// gives the whole model's, which its own particles do not).
  double centre_x = std::numeric_limits<double>::quiet_NaN(), centre_y = centre_x;
  bool part() const { return !global_node.empty(); }
};

/// What the problem lends a linear solver besides the matrices passed to analyzePattern() and
/// factorize(): the system matrix's action (MFEM's Operator::Mult) and a second matrix P to
/// precondition with (PETSc's Pmat), assembled on demand. Implemented above the seam
/// (src/app/linear_solvers.cpp, over the quasi-static problem); the solver holds it
/// (LinearSetup::system), and the problem behind it must outlive the solver.
class LinearSystem {
 public:
  virtual ~LinearSystem() = default;
  /// y = A v, for the solvers that never see A's entries (matrix_free: the matrices passed
  /// to analyzePattern() and factorize() are then empty placeholders).
  virtual void apply(const VectorXd& v, VectorXd& y) = 0;
  /// The unknowns (ascending) whose entries of v apply() reads for this process's rows (a rank
  /// of a distributed run: its ghosts); asked again after each change of pattern. A distributed
  /// solver then sends each rank those entries only.
  virtual std::vector<Index> reads() const = 0;
  /// Fills P at the state of the problem's last evaluation: its pattern first when P is empty,
  /// then its values. Solvers that read P only when they set up their kept preconditioner ask
  /// for it then and drop it afterwards, so that nobody holds P between set-ups (at a million
  /// particles 1.4 GB, and its assembly at every Newton iteration).
  virtual void preconditioner(SparseMatrix& P) = 0;
  /// While a solver sets up its preconditioner from a matrix it already holds, apply() is not
  /// called: the system may drop what apply() reads (suspend_action(), true when it did) and
  /// must have it back, the same bits, after resume_action(). The set-up of a million-particle
  /// run's V-cycle is then no longer its memory's peak.
  virtual bool suspend_action() { return false; }
  virtual void resume_action() {}
  /// P's rows of the contact zone at the state of the last evaluation, the other rows empty
  /// (QuasiStaticProblem::assemble_contact_zone): Pz empty, or the matrix of the last call.
  /// False when there is no zone (no contact, none asked for, over its cap, a part of a
  /// distributed run).
  virtual bool contact_zone_rows(SparseMatrix& /*Pz*/) { return false; }
};

/// What a solver is told once, when it is made (make_linear_solver()).
struct LinearSetup {
  /// The unknowns' particles and directions, for the solvers that build their own hierarchy or
  /// partition (belos, the bond_amg V-cycle: needs_unknown_layout()); empty for the others.
  UnknownLayout layout;
  /// Whether the run's matrices may be unsymmetric (frictional contact: slipping pairs), so
  /// that a preconditioner kept across Newton iterations is built for GMRES even when the
  /// state it is built at is symmetric (all pairs stuck); the MueLu V-cycle then smooths with
  /// Chebyshev degree 2 instead of 1.
  bool may_be_unsymmetric = false;
  /// The operator and the preconditioner's matrix, for the solvers that use them (matrix_free,
  /// cg with a bond preconditioner, belos with bond_factor or a matrix-free tangent).
  std::shared_ptr<LinearSystem> system;
};

/// What a solver is (LinearSolver::traits()).
struct LinearSolverTraits {
  std::string name;
  bool needs_symmetric = false;  ///< the method needs a symmetric (positive definite) matrix
  bool iterative = false;        ///< a Krylov solver, whose solves stop at a relative residual
};

/// What a solver has done (LinearSolver::stats()).
struct LinearSolverStats {
  int iterations = 0;    ///< Krylov iterations of the last solve (0 for direct solvers)
  double error = 0.0;    ///< estimated relative residual of the last solve (0 for direct solvers)
  long factorizations = 0;  ///< numeric factorisations so far (of A, or of the preconditioner's matrix)
  /// Seconds spent so far building preconditioners inside solve() (deferred set-ups), so that
  /// callers can count them as set-up, not as solving.
  double setup_seconds = 0.0;
};

/// How the next solves are to be done (LinearSolver::configure()).
struct LinearSolve {
  /// Whether the matrices are symmetric. Solvers that handle both (factor-preconditioned
  /// Krylov, belos with method auto) pick CG or GMRES by it.
  bool symmetric = true;
  /// Krylov solvers: the relative residual ||b - A x|| / ||b|| to stop at (an inexact Newton
  /// method's forcing term), never below the configured tolerance (solver.krylov.rtol,
  /// solver.belos.rtol), which stays the floor: 0 asks for the floor. Direct solvers ignore it.
  double rtol = 0.0;
  /// The problem's traits().preconditioner_state, for solvers that keep a preconditioner across
  /// factorize() calls while it serves (solvers/linear/preconditioner_reuse.hpp). A kept
  /// preconditioner is renewed because solves grew slower only once this has changed since it
  /// was built: while it has not, its matrix has changed only with the smooth deformation, and
  /// the slower solves are those of rougher right-hand sides (docs/theory/newton.md).
  std::uint64_t state = 0;
};

/// The linear-solver seam: a solver of A x = b, A given as a matrix (or, matrix_free, as
/// LinearSetup::system's action), its preconditioner inside it.
class LinearSolver {
 public:
  virtual ~LinearSolver() = default;

  /// Symbolic analysis of A's pattern; done once while the pattern does not change.
  virtual void analyzePattern(const SparseMatrix& A) = 0;
  /// Numeric factorisation (direct) or preconditioner set-up (iterative) of A. A solver may
  /// defer the set-up to the next solve(): a set-up that a renewal would replace before any
  /// solve is then never built (LinearSolverStats::setup_seconds counts it where it happens).
  virtual void factorize(const SparseMatrix& A) = 0;
  /// Solves A x = b with the last factorised A. For iterative solvers x holds the start
  /// value on entry.
  virtual void solve(const VectorXd& b, VectorXd& x) = 0;
  /// Success of the last call (Eigen::Success, NumericalIssue, NoConvergence...).
  virtual Eigen::ComputationInfo info() const = 0;

  virtual LinearSolverTraits traits() const = 0;
  virtual LinearSolverStats stats() const = 0;
  /// Settings of the next solves (LinearSolve); direct solvers ignore them.
  virtual void configure(const LinearSolve& /*next*/) {}
  /// For solvers that keep a preconditioner across factorize() calls while it serves
  /// (solvers/linear/preconditioner_reuse.hpp): the next factorize() builds a new one. Newton
  /// calls it when the tangent has changed in kind (contact pairs closed by the predictor).
  virtual void renew_preconditioner() {}

  std::string name() const { return traits().name; }
};

/// True when the solver that `options` name reads LinearSetup::layout.
bool needs_unknown_layout(const LinearOptions& options);

/// Makers of the solvers that live outside solvers/linear (Trilinos's: belos, the bond_amg
/// V-cycle), registered by the program before it makes any (src/app/linear_solvers.cpp).
using LinearSolverMaker = std::unique_ptr<LinearSolver> (*)(const LinearOptions& options, LinearSetup setup);
void register_linear_solver(LinearSolverKind kind, LinearSolverMaker make);

/// Creates the solver named by options.type (cholmod, umfpack, klu, ldlt, cg, bicgstab,
/// matrix_free, or a registered one: belos). Throws InputError for an unknown name or
/// preconditioner, or one that is not registered.
std::unique_ptr<LinearSolver> make_linear_solver(const LinearOptions& options, LinearSetup setup = {});

/// A message for a failed LinearSolver::info().
std::string describe(Eigen::ComputationInfo info);

}  // namespace peristat
