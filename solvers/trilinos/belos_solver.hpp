// solver.linear: belos. Trilinos's Krylov solvers (Belos) with MueLu or Ifpack2, or a factor
// of each rank's block of the bond matrix, behind the linear-solver seam: nothing above it
// knows Trilinos exists (src/app/linear_solvers.cpp registers these makers). The model and
// the assembly are the same on every rank; the matrix is distributed by rows (particles in
// contiguous ranges, both directions of a particle on one rank), solved by all ranks
// together, and the solution gathered on every rank (docs/guide/distributed.md). Compiled
// as C++17: MueLu's headers do not build as C++20.
#pragma once

#include <memory>

#include "solvers/linear/linear_solver.hpp"
#include "solvers/linear/preconditioner.hpp"

namespace peristat {

/// Starts MPI (through Tpetra) when it has not been started. Reads setup.layout (required),
/// and setup.system with a matrix-free tangent or the bond_factor preconditioner.
std::unique_ptr<LinearSolver> make_belos_solver(const BelosOptions& options, LinearSetup setup);

/// Who applies the MueLu V-cycle, and from what copy of its finest matrix.
enum class CycleApply {
  /// This program's OpenMP threads on MueLu's hierarchy (solvers/trilinos/threaded_cycle.hpp),
  /// the finest matrix in 2 x 2 blocks of floats; for GMRES (LinearSetup::may_be_unsymmetric)
  /// pre-smoothing of degree 1 (ThreadedCycle::from's pre_degree). The default.
  threads,
  /// The same threads, blocks of doubles and MueLu's smoothing: MueLu's own cycle, to
  /// rounding (for tests).
  threads_exact,
  /// MueLu's apply, on one core (for comparison).
  muelu,
};

/// One MueLu V-cycle of the matrix it factorises (smoothed aggregation, in this process), as
/// the preconditioner of factor-preconditioned Krylov (solver.krylov.preconditioner: bond_amg).
/// Reads setup.layout (two unknowns per particle, the rigid-body modes) and
/// setup.may_be_unsymmetric (the cycle may serve GMRES: Chebyshev degree 2).
std::unique_ptr<Preconditioner> make_muelu_cycle(const LinearSetup& setup, CycleApply apply = CycleApply::threads);

/// Above this many rows the MueLu V-cycle puts memory before set-up time: the Galerkin
/// product without its AP temporary (docs/performance.md, "The V-cycle").
inline constexpr long long kAmgMemoryFirstRows = 2'500'000;

}  // namespace peristat
