// The program's linear solvers: Trilinos's registered behind the linear-solver seam (so that
// solvers/linear knows nothing of them), and Newton's solver for a quasi-static problem, told
// at construction what it reads of the problem.
#pragma once

#include <memory>

#include "assembly/quasi_static.hpp"
#include "discretisation/model_part.hpp"
#include "scene/scene.hpp"
#include "solvers/linear/linear_solver.hpp"

namespace peristat {

/// Registers solver.linear: belos and the bond_amg V-cycle (solvers/trilinos/) with the seam.
/// Idempotent: main() calls it first, make_problem_linear_solver() and the tests' support too.
void register_linear_solvers();

/// The solver `options` name (resolved, not `auto`) for Newton on `problem`, with the problem
/// as its operator and preconditioner's matrix (LinearSystem), its unknowns' layout where the
/// solver reads one (with `part`, part_unknown_layout()'s: collective under mpirun), and
/// whether the scene's contact pairs may slip. `problem` must outlive the solver.
std::unique_ptr<LinearSolver> make_problem_linear_solver(const Scene& scene, QuasiStaticProblem& problem,
                                                         const LinearOptions& options,
                                                         const ModelPart* part = nullptr);

}  // namespace peristat
