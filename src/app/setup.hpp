// The wiring from a validated Scene to the objects that solve it, shared by `peristat run`,
// `check` and the tests: each component takes its own options.
#pragma once

#include <memory>
#include <string>

#include "app/run_plan.hpp"
#include "assembly/quasi_static.hpp"
#include "discretisation/model_part.hpp"
#include "scene/scene.hpp"
#include "solvers/linear/linear_solver.hpp"
#include "solvers/step_solver.hpp"

namespace peristat {

/// What the problem models, from the scene, with the tangent's form and the bond
/// preconditioner the plan resolved.
ProblemOptions problem_options(const Scene& scene, const RunPlan& plan);
/// The same for the scene as it stands (scene_plan(): `auto` unresolved assembles the tangent).
ProblemOptions problem_options(const Scene& scene);

/// The rows rank `rank` of `ranks` assembles (ProblemOptions::rows): each particle of `model`
/// (the scene's whole model) owned as LatticePartition::owner() says, by
/// solver.belos.partition (every rank computes the same owners from the census). Every row
/// when ranks <= 1.
OwnedRows owned_rows(const Scene& scene, const Model& model, int rank, int ranks);

/// The families a rank with `rows` evaluates: its particles and those without a row, and every
/// particle within `rings` stencils of them (Model::family_held, from lattice offsets).
std::vector<char> families_to_hold(const Model& model, const OwnedRows& rows, int rings);

/// Each unknown's particle and direction, and the particles' positions (LinearSolver's hint).
UnknownLayout unknown_layout(const Model& model, Index n_unknowns);

/// This rank's part of the model (docs/guide/distributed.md, "The partitioned model"): the
/// scene's census (take_census(), a few bytes per lattice point), its regions by
/// solver.belos.partition, and the part built from them (build_part(): `rings` of families
/// around its particles, part_rings(), and the `extra` particles, PartsOutgrown's). No rank
/// builds the whole model.
ModelPart part_model(const Scene& scene, int rings, int rank, int ranks, const std::vector<std::int64_t>& extra = {});
/// The same with the rings of the run the scene would make on `ranks` (make_run_plan()).
ModelPart part_model(const Scene& scene, int rank, int ranks);
/// Puts rank `rank`'s part into the problem's options: its rows, owned unknowns and global
/// ids (data only: the problem builds its exchanges from them on its Ranks).
void set_part(ProblemOptions& options, const ModelPart& part, int rank);
/// The problem's options on that part: problem_options() and set_part().
ProblemOptions part_problem_options(const Scene& scene, const RunPlan& plan, const ModelPart& part, int rank);
/// The layout of a rank's part of the model (collective): the nodes numbered rank by rank
/// (each rank's own in the part's order, from the sum of the lower ranks' counts), its ghosts'
/// numbers from their owners (OwnedEntriesExchange), and the whole model's centre.
UnknownLayout part_unknown_layout(const ModelPart& part, const Ranks& ranks);

/// The step solver the plan names (Newton or ADR); `linear` receives Newton's linear
/// solver (it must outlive the step solver) and stays empty for ADR. With `part`, the problem
/// is built on that rank's part of the model (ProblemOptions::owned_unknowns): Newton with
/// belos only, its layout part_unknown_layout()'s (collective). The problem must have been
/// built with the plan's tangent form (problem_options() of the same plan).
std::unique_ptr<StepSolver> make_step_solver(const Scene& scene, const RunPlan& plan, QuasiStaticProblem& problem,
                                             std::unique_ptr<LinearSolver>& linear,
                                             const ModelPart* part = nullptr);
/// The same for the scene as it stands (scene_plan()); an unresolved `auto` is resolved here
/// for the problem's unknowns on one process, and matrix_free becomes cg on a problem whose
/// tangent is assembled (callers that did not plan the run: tests).
std::unique_ptr<StepSolver> make_step_solver(const Scene& scene, QuasiStaticProblem& problem,
                                             std::unique_ptr<LinearSolver>& linear,
                                             const ModelPart* part = nullptr);

}  // namespace peristat
