// The preconditioner of factor-preconditioned Krylov (solvers/linear/factor_krylov.hpp), as a
// solver (MFEM's Solver used as a preconditioner): the factor (CHOLMOD) or the V-cycle (MueLu)
// of a matrix, kept across Newton iterations and load steps. Its "solve" applies M^-1.
#pragma once

#include <memory>
#include <string>

#include <Eigen/SparseCore>

#include "core/options.hpp"
#include "core/types.hpp"
#include "solvers/linear/linear_solver.hpp"

namespace peristat {

class Preconditioner {
 public:
  virtual ~Preconditioner() = default;

  /// Symbolic analysis of P's pattern; done once while the pattern does not change.
  virtual void analyzePattern(const SparseMatrix& P) = 0;
  /// The factor or hierarchy of P (load() and set_up_loaded() together).
  virtual void factorize(const SparseMatrix& P) = 0;
  /// factorize(P) in two halves: load() takes what the preconditioner needs from P, after
  /// which it does not read P again and may empty it (free its memory); set_up_loaded() builds
  /// the rest, which a preconditioner may defer to it (MueLu's hierarchy).
  virtual void load(SparseMatrix& P) { factorize(P); }
  virtual void set_up_loaded() {}
  /// Drops the factor or hierarchy that the next load() replaces, before the caller assembles
  /// that load()'s matrix: the two are then never held together.
  virtual void release_factor() {}
  /// x = M^-1 b.
  virtual void solve(VectorIn b, VectorXd& x) = 0;
  /// Success of the last call.
  virtual Eigen::ComputationInfo info() const = 0;
  virtual std::string name() const = 0;
  /// Factorisations (or hierarchies) built so far.
  virtual long factorizations() const = 0;
  /// The bytes of matrix data one solve() reads, when the preconditioner knows them (the
  /// threaded V-cycle), else 0: the roofline's figure (peristat_bench cycle).
  virtual double matrix_bytes_per_solve() const { return 0.0; }
  /// Whether solve() is P^-1 to round-off (a factor), not an approximation of it (a V-cycle):
  /// GMRES then adds no zone correction (zone_correction.hpp).
  virtual bool exact() const { return false; }
  /// Whether solve() is a symmetric operator for a symmetric P, as CG needs of its
  /// preconditioner; the Krylov solver runs GMRES on a symmetric system when it is not (the
  /// V-cycle that serves GMRES: muelu_cycle.cpp).
  virtual bool symmetric() const { return true; }
};

/// A direct LinearSolver (CHOLMOD) as a preconditioner: its factor of P.
std::unique_ptr<Preconditioner> factor_preconditioner(std::unique_ptr<LinearSolver> factor);

/// Makers of the preconditioners that live outside solvers/linear (Trilinos's bond_amg
/// V-cycle), registered by the program before it makes any (src/app/linear_solvers.cpp).
using PreconditionerMaker = std::unique_ptr<Preconditioner> (*)(const LinearSetup& setup);
void register_preconditioner(PreconditionerKind kind, PreconditionerMaker make);
/// The registered maker's preconditioner; throws InputError when none is registered.
std::unique_ptr<Preconditioner> make_registered_preconditioner(PreconditionerKind kind, const LinearSetup& setup);

}  // namespace peristat
