// Krylov iterations preconditioned by a reused sparse factorisation: CG while the matrix is
// symmetric, restarted GMRES otherwise. The factor is of either the system matrix itself,
// kept across Newton iterations and load steps, or of a cheaper matrix P that the problem
// supplies (the bond-based part of the tangent). The factor is renewed only when the
// iteration count climbs (docs/theory/newton.md, "Factor-preconditioned Krylov (`cg`)").
#pragma once

#include <memory>

#include "solvers/linear/linear_solver.hpp"

namespace peristat {

enum class FactorSource {
  system_matrix,         ///< factor A itself (refreshed when iterations climb)
  preconditioner_matrix  ///< factor the P that set_preconditioner_source() assembles
};

/// `factor` is a direct solver for symmetric matrices (CHOLMOD in practice). With
/// `matrix_free` the system matrix is applied through LinearSolver::set_operator() (source
/// must be preconditioner_matrix).
std::unique_ptr<LinearSolver> make_factor_preconditioned_krylov(std::unique_ptr<LinearSolver> factor,
                                                                FactorSource source,
                                                                const LinearOptions& options,
                                                                bool matrix_free = false);

}  // namespace peristat
