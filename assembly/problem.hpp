// The small interface the solvers see (STYLE.md, seam 3): residual, tangent or its action,
// the preconditioner source, commit and revert, checks; norms come from the unknowns' space.
// Header-only and free of physics so solvers/ never includes materials or contact.
#pragma once

#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

#include "core/types.hpp"
#include "parallel/ranks.hpp"

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

/// What the solvers read of the last evaluate() besides its numbers: the tangent's kind, its
/// pattern's version and the discrete state (Problem::traits()).
struct ProblemTraits {
  /// The tangent assembled by the last evaluate() that assembled one is symmetric (a Cholesky
  /// factorisation or CG applies).
  bool tangent_symmetric = true;
  /// The tangent does not depend on x (linear problem: factorise once).
  bool tangent_constant = false;
  /// Changes whenever the tangent's pattern does (e.g. contact partners found after a large
  /// slide): matrices from make_tangent() and PreconditionerSource::make_preconditioner(), and
  /// any symbolic factorisation of them, must then be made again.
  std::uint64_t structure_version = 0;
  /// A hash of the discrete state of the last evaluate() (e.g. an active set); 0 for a smooth
  /// problem. Newton counts the iterations that change it and detects cycling.
  std::uint64_t state_signature = 0;
  /// A hash of what a preconditioner of the tangent depends on besides the smooth
  /// deformation: state_signature and, for a problem whose bonds break, the broken bonds
  /// (state_signature when nothing else). Krylov solvers renew a kept preconditioner for slow
  /// solves only after it has changed (solvers/linear/preconditioner_reuse.hpp). Collective:
  /// every rank has the same.
  std::uint64_t preconditioner_state = 0;
};

/// How evaluate() computes (Problem::set_evaluation_mode()); one mode at a time.
enum class EvaluationMode {
  /// Every row of the residual and, when asked, of the tangent.
  standard,
  /// evaluate() with a tangent gives each pair that touches without a force (at the edge of
  /// its contact gate) the stiffness of a closed, stuck pair: the Euler predictor's tangent, so
  /// that a load increment which pushes bodies together is predicted with them in contact
  /// (docs/theory/newton.md, "Predictor"). Residuals are unchanged. Only a problem with such
  /// pairs has it.
  touching_closed,
  /// Distributed ADR (docs/guide/distributed.md): evaluate() without a tangent computes the
  /// residual only in this process's rows (its own unknowns), and zero in the others;
  /// force_scale() stays the norm over every component (summed over the ranks), and every other
  /// result of that evaluate() (energy, reactions) is undefined until the next evaluate() in
  /// the standard mode. Only a problem split among ranks has it.
  own_rows_only
};

/// The vector space of a problem's unknowns: how long its vectors are, and the Euclidean norm
/// and the finiteness of one, the same on every rank. On a rank's part of the model (ModelPart:
/// its own unknowns first, then a ghost tail) they are taken over the own entries and combined
/// over the ranks (collective: every rank calls them at the same point); otherwise the vector
/// is whole here.
class UnknownSpace {
 public:
  /// n unknowns, every one whole in this process.
  explicit UnknownSpace(Index n) : m_size(n), m_owned(n) {}
  /// A part's n unknowns, of which the first `owned` are this rank's; `ranks` combines them.
  UnknownSpace(Index n, Index owned, const Ranks& ranks) : m_size(n), m_owned(owned), m_ranks(&ranks) {}

  /// The length of every vector over the unknowns (a part's ghost tail included).
  Index size() const { return m_size; }
  /// The entries this process owns: the first ones (every one when the vector is whole here).
  Index owned() const { return m_owned; }
  double norm(const VectorXd& v) const {
    if (!m_ranks) return v.norm();
    return std::sqrt(m_ranks->sum(v.head(m_owned).squaredNorm()));
  }
  bool all_finite(const VectorXd& v) const {
    if (!m_ranks) return v.allFinite();
    return !m_ranks->any(!v.head(m_owned).allFinite());
  }

 private:
  Index m_size, m_owned;
  const Ranks* m_ranks = nullptr;  ///< null: whole here
};

/// What a problem offers towards preconditioning its tangent (Problem::preconditioner_source()).
class PreconditionerSource {
 public:
  /// A cheaper symmetric positive definite matrix over the same unknowns whose factor
  /// preconditions Krylov solves with the tangent (PETSc's Pmat), with its pattern and zero
  /// values. Empty when the problem offers none.
  virtual SparseMatrix make_preconditioner() = 0;
  /// Fills the values of P (from make_preconditioner()) at the state of the last evaluate().
  virtual void assemble_preconditioner(SparseMatrix& P) = 0;
  /// Adds to `row_sums` (per unknown) a bound of the absolute row sums of tangent terms that
  /// may switch on later in a step and are absent from the current tangent. ADR's fictitious
  /// density (its diagonal preconditioner) covers them.
  virtual void add_stiffness_bound(VectorXd& row_sums) const = 0;

 protected:
  ~PreconditionerSource() = default;
};

/// State that changes only between converged equilibria and never goes back once committed
/// (e.g. damage: bonds break), with the undo of a trial change (Problem::irreversible_state()).
class IrreversibleState {
 public:
  /// Advances the irreversible state at the converged, committed state x: a trial change of at
  /// most `at_most` items when at_most > 0, the most critical first. Returns how many items
  /// changed; 0 when nothing did, and then the load step is done. The change is kept by the
  /// next Problem::commit() and undone by revert_irreversible_state().
  virtual Index advance_irreversible_state(const VectorXd& x, Index at_most = 0) = 0;
  /// Undoes the last advance_irreversible_state(), whose re-solve did not converge.
  virtual void revert_irreversible_state() = 0;

 protected:
  ~IrreversibleState() = default;
};

class Problem {
 public:
  virtual ~Problem() = default;

  // ---- The unknowns and the load.
  /// The unknowns' vector space (free displacement components): their count, and the norm
  /// and finiteness of a vector over them. The same for the problem's whole life.
  virtual UnknownSpace unknowns() const = 0;
  /// Number of unknowns: the length of every vector over them.
  Index n_unknowns() const { return unknowns().size(); }

  /// Sets the trial load factor: prescribed components become lambda times their value.
  virtual void set_load_factor(double lambda) = 0;
  virtual double load_factor() const = 0;

  // ---- Residual, tangent or its action.
  /// Residual r(x) = dPi/dx over the unknowns and, if K is given, the tangent dr/dx
  /// (K must come from make_tangent(); only its values are written).
  virtual void evaluate(const VectorXd& x, VectorXd& r, SparseMatrix* K) = 0;
  /// Force scale of the last evaluate(): the norm of the internal forces over every
  /// component, prescribed ones (the reactions) included. The relative residual is
  /// ||r|| / force_scale() (docs/theory/newton.md).
  virtual double force_scale() const = 0;
  /// How the next evaluate() computes (EvaluationMode); standard until set otherwise. Returns
  /// false, and does nothing, when the problem has no such mode (standard it always has).
  virtual bool set_evaluation_mode(EvaluationMode mode) { return mode == EvaluationMode::standard; }
  /// The tangent's kind, its pattern's version and the discrete state of the last evaluate().
  virtual ProblemTraits traits() const = 0;

  /// A matrix with the tangent's sparsity pattern and zero values. Each call makes a new one.
  /// Empty for a matrix-free problem (apply_tangent()).
  virtual SparseMatrix make_tangent() const = 0;
  /// y = K v with the tangent of the last evaluate() given a K; problems that never assemble
  /// it implement this (solver.linear: matrix_free).
  virtual void apply_tangent(const VectorXd& /*v*/, VectorXd& /*y*/) {
    throw std::logic_error("apply_tangent: this problem assembles its tangent");
  }

  // ---- Preconditioner source.
  /// The problem's preconditioner matrix and ADR's stiffness bound, or null when it offers
  /// neither (no preconditioner matrix, no terms beyond the current tangent).
  virtual PreconditionerSource* preconditioner_source() { return nullptr; }

  // ---- Commit and revert.
  /// Constraints enforced by multipliers (an augmented Lagrangian, e.g. exact contact): at a
  /// converged state x, says whether they hold or updates the multipliers, after which the
  /// caller solves again at the same load. The trial multipliers start from the committed
  /// ones at each set_load_factor().
  virtual ConstraintUpdate update_multipliers(const VectorXd& /*x*/) { return {}; }
  /// The irreversible state (advanced at a converged state, undone when its re-solve fails),
  /// or null when the problem has none (e.g. the scene models no failure): the load stepping
  /// then asks nothing of it.
  virtual IrreversibleState* irreversible_state() { return nullptr; }
  /// Accepts x as the converged state of the current load factor (history is committed).
  virtual void commit(const VectorXd& x) = 0;
  /// Zeroes the components of an increment that the problem holds where they are (fragments,
  /// docs/theory/failure.md): a predictor or a solve moves only what the problem solves for.
  virtual void hold_increment(VectorXd& /*dx*/) const {}

  // ---- Checks.
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
};

}  // namespace peristat
