// The linear-solver seam. Method names follow Eigen (analyzePattern, factorize, solve,
// info) so Eigen's and SuiteSparse's solvers fit behind it; a distributed backend
// (Trilinos) will be one more implementation. Nothing here knows about physics.
#pragma once

#include <cstdint>
#include <functional>
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

class LinearSolver {
 public:
  virtual ~LinearSolver() = default;

  /// Symbolic analysis of A's pattern; done once while the pattern does not change.
  virtual void analyzePattern(const SparseMatrix& A) = 0;
  /// Numeric factorisation (direct) or preconditioner set-up (iterative) of A. A solver may
  /// defer the set-up to the next solve(): a set-up that a renewal would replace before any
  /// solve is then never built (setup_seconds() counts it where it happens).
  virtual void factorize(const SparseMatrix& A) = 0;
  /// Solves A x = b with the last factorised A. For iterative solvers x holds the start
  /// value on entry.
  virtual void solve(const VectorXd& b, VectorXd& x) = 0;
  /// Success of the last call (Eigen::Success, NumericalIssue, NoConvergence...).
  virtual Eigen::ComputationInfo info() const = 0;

  virtual std::string name() const = 0;
  /// True if the method needs a symmetric (positive definite) matrix.
  virtual bool needs_symmetric() const = 0;
  /// Krylov iterations of the last solve (0 for direct solvers).
  virtual int iterations() const { return 0; }
  /// Estimated relative residual of the last solve (0 for direct solvers).
  virtual double error() const { return 0.0; }
  /// True for Krylov solvers, whose solves stop at a relative residual.
  virtual bool iterative() const { return false; }
  /// Krylov solvers: the relative residual ||b - A x|| / ||b|| the next solves stop at (an
  /// inexact Newton method's forcing term), never below the configured tolerance
  /// (solver.krylov.rtol, solver.belos.rtol), which stays the floor. Direct solvers ignore it.
  virtual void set_relative_tolerance(double /*rtol*/) {}
  /// Numeric factorisations performed so far (of A, or of the preconditioner's matrix).
  virtual long factorizations() const = 0;
  /// Seconds spent so far building preconditioners inside solve() (deferred set-ups), so that
  /// callers can count them as set-up, not as solving.
  virtual double setup_seconds() const { return 0.0; }

  /// True when the solver is preconditioned by the factor of a second matrix P that the
  /// caller passes with set_preconditioner_matrix() before each factorize() (PETSc's Pmat),
  /// or, when takes_preconditioner_source(), assembles through the source when it sets up.
  virtual bool uses_preconditioner_matrix() const { return false; }
  /// P must stay alive and keep its pattern until the next call.
  virtual void set_preconditioner_matrix(const SparseMatrix& /*P*/) {}
  /// Fills P (pattern and values) at the state of the problem's last evaluation.
  using MatrixSource = std::function<void(SparseMatrix& P)>;
  /// True for solvers that read P only when they set up their kept preconditioner: they take
  /// set_preconditioner_source() instead of set_preconditioner_matrix(), ask for P when they
  /// set up and drop it afterwards, so nobody holds P between set-ups (at a million
  /// particles 1.4 GB, and its assembly at every Newton iteration).
  virtual bool takes_preconditioner_source() const { return false; }
  virtual void set_preconditioner_source(MatrixSource /*source*/) {}
  /// factorize(A) in two halves: load() takes what the solver needs from A, after which it
  /// does not read A again and may empty it (free its memory); set_up_loaded() builds the
  /// rest, which a solver may defer to it (MueLu's hierarchy). factorize() = both.
  virtual void load(SparseMatrix& A) { factorize(A); }
  virtual void set_up_loaded() {}
  /// Drops the factor or preconditioner that the next factorize() replaces, before the
  /// caller assembles that factorize()'s matrix: the two are then never held together.
  virtual void release_factor() {}

  /// Tells the solver whether the next matrices are symmetric. Solvers that handle both
  /// (factor-preconditioned Krylov: CG or GMRES) pick their method by it.
  virtual void set_symmetric(bool /*symmetric*/) {}
  /// Tells the solver, once, whether the run's matrices may be unsymmetric (frictional
  /// contact: slipping pairs), so that a preconditioner kept across Newton iterations is built
  /// for GMRES even when the state it is built at is symmetric (all pairs stuck); the MueLu
  /// V-cycle then smooths with Chebyshev degree 2 instead of 1.
  virtual void set_may_be_unsymmetric(bool /*may*/) {}
  /// For solvers that keep a preconditioner across factorize() calls while it serves
  /// (solvers/linear/preconditioner_reuse.hpp): the next factorize() builds a new one. Newton
  /// calls it when the tangent has changed in kind (contact pairs closed by the predictor).
  virtual void renew_preconditioner() {}
  /// For the same solvers: the problem's preconditioner_state() at the next solve(). A kept
  /// preconditioner is renewed because solves grew slower only once this has changed since
  /// it was built: while it has not, its matrix has changed only with the smooth deformation,
  /// and the slower solves are those of rougher right-hand sides (docs/theory/newton.md).
  virtual void set_state(std::uint64_t /*state*/) {}

  /// y = A v, for solvers that never see A's entries.
  using Operator = std::function<void(const VectorXd& v, VectorXd& y)>;
  /// True when the solver applies the system matrix through set_operator() (matrix_free):
  /// the matrices passed to analyzePattern() and factorize() are then empty placeholders.
  virtual bool needs_operator() const { return false; }
  virtual void set_operator(Operator /*apply*/) {}
  /// The unknowns (ascending) whose entries of v the operator reads for this process's rows
  /// (a rank of a distributed run: its ghosts); asked again after each change of pattern. A
  /// distributed solver then sends each rank those entries only. Without it, every entry.
  using OperatorReads = std::function<std::vector<Index>()>;
  virtual void set_operator_reads(OperatorReads /*reads*/) {}

  /// True when the solver wants set_unknown_layout() before analyzePattern().
  virtual bool needs_unknown_layout() const { return false; }
  /// The unknowns' particles and directions (see needs_unknown_layout()).
  virtual void set_unknown_layout(const UnknownLayout& /*layout*/) {}
};

/// Creates the solver named by options.type (cholmod, umfpack, klu, ldlt, cg, bicgstab,
/// belos: Trilinos, solvers/trilinos/).
/// Throws InputError for an unknown name or preconditioner.
std::unique_ptr<LinearSolver> make_linear_solver(const LinearOptions& options);

/// A message for a failed LinearSolver::info().
std::string describe(Eigen::ComputationInfo info);

}  // namespace peristat
