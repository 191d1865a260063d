// Krylov iterations preconditioned by a reused sparse factorisation: CG while the matrix is
// symmetric, restarted GMRES otherwise. The factor is of either the system matrix itself,
// kept across Newton iterations and load steps, or of a cheaper matrix P that the problem
// supplies (the bond-based part of the tangent). The factor is renewed only when the
// iteration count climbs (docs/theory/newton.md, "Factor-preconditioned Krylov (`cg`)").
#pragma once

#include <memory>

#include "solvers/linear/linear_solver.hpp"
#include "solvers/linear/preconditioner.hpp"

namespace peristat {

enum class FactorSource {
  system_matrix,         ///< factor A itself (refreshed when iterations climb)
  preconditioner_matrix  ///< factor the P that LinearSystem::preconditioner() assembles
};

/// `factor` is a factor of symmetric matrices (CHOLMOD) or a V-cycle. With `matrix_free` the
/// system matrix is applied through LinearSystem::apply() (source must be
/// preconditioner_matrix). `system` serves P and the action; it may be null when neither is used.
std::unique_ptr<LinearSolver> make_factor_preconditioned_krylov(std::unique_ptr<Preconditioner> factor,
                                                                FactorSource source,
                                                                const LinearOptions& options,
                                                                std::shared_ptr<LinearSystem> system,
                                                                bool matrix_free = false);

}  // namespace peristat
