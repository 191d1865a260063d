// The small interface the solvers see (STYLE.md, seam 3): residual, tangent, load factor,
// irreversible state, commit. Header-only and free of physics so solvers/ never includes
// materials or contact.
#pragma once

#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

#include "core/types.hpp"

namespace peristat {

/// Outcome of Problem::update_multipliers().
struct ConstraintUpdate {
  enum class Status {
    satisfied,  ///< the constraints hold to their tolerance: the state may be accepted
    updated,    ///< multipliers changed: solve again at the same load
    exhausted   ///< the update budget is spent: the attempt fails (`message` says why)
  };
  Status status = Status::satisfied;
  double violation = 0.0;  ///< largest violation, in the constraint's own relative measure
  int updates = 0;         ///< updates made so far in this increment
  std::string message;
};

class Problem {
 public:
  virtual ~Problem() = default;

  /// Number of unknowns (free displacement components).
  virtual Index n_unknowns() const = 0;

  /// Sets the trial load factor: prescribed components become lambda times their value.
  virtual void set_load_factor(double lambda) = 0;
  virtual double load_factor() const = 0;

  /// Residual r(x) = dPi/dx over the unknowns and, if K is given, the tangent dr/dx
  /// (K must come from make_tangent(); only its values are written).
  virtual void evaluate(const VectorXd& x, VectorXd& r, SparseMatrix* K) = 0;

  /// Force scale of the last evaluate(): the norm of the internal forces over every
  /// component, prescribed ones (the reactions) included. The relative residual is
  /// ||r|| / force_scale() (docs/theory/newton.md).
  virtual double force_scale() const = 0;

  /// A matrix with the tangent's sparsity pattern and zero values. Each call makes a new one.
  /// Empty for a matrix-free problem (apply_tangent()).
  virtual SparseMatrix make_tangent() const = 0;
  /// y = K v with the tangent of the last evaluate() given a K; problems that never assemble
  /// it implement this (solver.linear: matrix_free).
  virtual void apply_tangent(const VectorXd& /*v*/, VectorXd& /*y*/) {
    throw std::logic_error("apply_tangent: this problem assembles its tangent");
  }
  /// Changes whenever the tangent's pattern does (e.g. contact partners found after a large
  /// slide): matrices from make_tangent() and make_preconditioner(), and any symbolic
  /// factorisation of them, must then be made again.
  virtual std::uint64_t structure_version() const { return 0; }

  /// True when the tangent assembled by the last evaluate() that assembled one is symmetric
  /// (a Cholesky factorisation or CG applies).
  virtual bool tangent_symmetric() const = 0;

  /// True when the tangent does not depend on x (linear problem: factorise once).
  virtual bool tangent_constant() const = 0;

  /// An optional cheaper symmetric positive definite matrix over the same unknowns whose
  /// factor preconditions Krylov solves with the tangent (PETSc's Pmat). Empty when the
  /// problem offers none.
  virtual SparseMatrix make_preconditioner() { return {}; }
  /// Fills the values of P (from make_preconditioner()) at the state of the last evaluate().
  virtual void assemble_preconditioner(SparseMatrix& /*P*/) {}

  /// While on, evaluate() with a tangent gives each pair that touches without a force (at the
  /// edge of its contact gate) the stiffness of a closed, stuck pair: the Euler predictor's
  /// tangent, so that a load increment which pushes bodies together is predicted with them
  /// in contact (docs/theory/newton.md, "Predictor"). Residuals are unchanged. Returns false,
  /// and does nothing, when the problem has no such pairs.
  virtual bool set_touching_closed(bool /*on*/) { return false; }

  /// Distributed ADR (docs/guide/distributed.md): while on, evaluate() without a tangent
  /// computes the residual only in this process's rows (its own unknowns), and zero in the
  /// others; force_scale() stays the norm over every component (summed over the ranks), and
  /// every other result of that evaluate() (energy, reactions) is undefined until the next
  /// evaluate() with it off. Returns false, and does nothing, for a problem that is not split
  /// among ranks.
  virtual bool set_own_rows_only(bool /*on*/) { return false; }

  /// A hash of the discrete state of the last evaluate() (e.g. an active set); 0 for a
  /// smooth problem. Newton counts the iterations that change it and detects cycling.
  virtual std::uint64_t state_signature() const { return 0; }

  /// A hash of what a preconditioner of the tangent depends on besides the smooth
  /// deformation: state_signature() and, for a problem whose bonds break, the broken bonds.
  /// Krylov solvers renew a kept preconditioner for slow solves only after it has changed
  /// (solvers/linear/preconditioner_reuse.hpp). Collective: every rank returns the same.
  virtual std::uint64_t preconditioner_state() const { return state_signature(); }

  /// Adds to `row_sums` (per unknown) a bound of the absolute row sums of tangent terms that
  /// may switch on later in a step and are absent from the current tangent. ADR's
  /// fictitious density covers them.
  virtual void add_stiffness_bound(VectorXd& /*row_sums*/) const {}

  /// Advances the irreversible state at the converged, committed state x (e.g. damage): a
  /// trial change of at most `at_most` items when at_most > 0, the most critical first.
  /// Returns how many items changed; 0 when nothing did (or the problem has no such state),
  /// and then the load step is done. The change is kept by the next commit() and undone by
  /// revert_irreversible_state().
  virtual Index advance_irreversible_state(const VectorXd& /*x*/, Index /*at_most*/ = 0) { return 0; }
  /// Undoes the last advance_irreversible_state(), whose re-solve did not converge.
  virtual void revert_irreversible_state() {}

  /// Constraints enforced by multipliers (an augmented Lagrangian, e.g. exact contact): at a
  /// converged state x, says whether they hold or updates the multipliers, after which the
  /// caller solves again at the same load. The trial multipliers start from the committed
  /// ones at each set_load_factor().
  virtual ConstraintUpdate update_multipliers(const VectorXd& /*x*/) { return {}; }

  /// Checks a converged state before it is accepted; returns why it must be rejected (e.g. a
  /// contact pair whose particles have passed each other), or "" when it may be accepted.
  /// The load stepping calls it right after evaluate(x, r, nullptr). A rejected state is cut
  /// back; a state no smaller increment can avoid throws ModelLimit instead, and the run stops
  /// at the last converged state with the reason.
  virtual std::string check_converged_state(const VectorXd& /*x*/) { return {}; }
  /// What every accepted state has been checked for (summary.json run.checks): the load
  /// stepping's own checks (finite state, residual recomputed within the solver's
  /// tolerance), and what check_converged_state() adds.
  virtual std::vector<std::string> state_checks() const {
    return {"finite state", "residual recomputed from scratch within the solver's tolerance"};
  }

  /// The Euclidean norm of a vector over the unknowns, and whether it is finite, the same on
  /// every rank: a problem on a rank's part of the model (ModelPart: its own unknowns first,
  /// then a ghost tail) sums its own entries over the ranks; otherwise the vector is whole
  /// here. Collective in a distributed run: every rank calls them at the same point.
  virtual double norm(const VectorXd& v) const { return v.norm(); }
  virtual bool all_finite(const VectorXd& v) const { return v.allFinite(); }

  /// Accepts x as the converged state of the current load factor (history is committed).
  virtual void commit(const VectorXd& x) = 0;
};

}  // namespace peristat
