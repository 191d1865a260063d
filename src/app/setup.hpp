// The wiring from a validated Scene to the objects that solve it, shared by `peristat run`,
// `check` and the tests: each component takes its own options.
#pragma once

#include <memory>
#include <string>

#include "assembly/quasi_static.hpp"
#include "discretisation/model_part.hpp"
#include "scene/scene.hpp"
#include "solvers/distribution.hpp"
#include "solvers/linear/linear_solver.hpp"
#include "solvers/step_solver.hpp"

namespace peristat {

/// What `solver.linear: auto` picked, and why (printed by run and check, in summary.json).
struct LinearChoice {
  LinearSolverKind kind = LinearSolverKind::cg;
  std::string reason;
};

/// Models with at most this many unknowns and no friction get a direct factor (CHOLMOD):
/// whole runs of the tension plate, best of two, 2 cores: 1,249 unknowns 0.19 s against cg's
/// 0.28 s, 3,196 0.48 against 0.41 s, 4,994 0.59 against 0.57 s, 19,970 3.2 against 2.2 s
/// (docs/performance.md, "Fast by default"); below the crossover a factor is also exact.
inline constexpr double kDirectMaxUnknowns = 2500.0;
/// With matrix_free, `auto` shortens the bond preconditioner's radius (unless the scene sets
/// solver.krylov.bond_radius) to 2.0 dx above kMediumBondsAbove unknowns and 1.42 dx (the 8
/// nearest neighbours) above kShortBondsAbove: measured on the tension plate at 300 x 300
/// and 700 x 700 and on the contact cases (docs/performance.md, "Matrix-free").
inline constexpr double kMediumBondsAbove = 100000.0;
inline constexpr double kShortBondsAbove = 500000.0;

/// The linear solver `solver.linear: auto` stands for, from the number of unknowns (an
/// estimate before discretising, or the model's), the scene's physics and the MPI ranks:
/// belos under mpirun; else CHOLMOD for small models without friction; else matrix_free
/// (CG on the bond factor, GMRES while pairs slip, with the tangent's action: faster and
/// smaller than the assembled cg path on every case measured). docs/performance.md.
LinearChoice choose_linear_solver(const Scene& scene, double unknowns, int ranks);

/// Replaces `auto` in scene.solver.linear.type by choose_linear_solver()'s pick for the
/// estimated unknowns (estimate_size, before discretising); returns its reason, or "" when the
/// scene named a solver (an explicit choice always wins) or runs ADR.
std::string resolve_linear_solver(Scene& scene, int ranks);

/// What the problem models, from the scene.
ProblemOptions problem_options(const Scene& scene);

/// The rows rank `rank` of `ranks` assembles (ProblemOptions::rows): by
/// solver.belos.partition, strips or Zoltan2's RCB of the particles that have an unknown,
/// then the particles without one by proximity (complete_owners(); every rank computes the
/// same owners). Every row when ranks <= 1.
OwnedRows owned_rows(const Scene& scene, const Model& model, int rank, int ranks);

/// Whether each rank of a distributed run holds only the bond families it evaluates
/// (solver.belos.bonds, docs/guide/distributed.md "Partitioned bonds"), how deep, and why.
/// With a failure criterion too (its decisions gathered over the ranks). The matrix-free tangent (Newton with
/// belos, the default under mpirun) reads the families of a rank's particles and of their neighbours: one
/// ring; an assembled tangent (belos's `assembled`, or ADR's for its density) reads a column's families two
/// horizons from its rows: two rings. Call after resolve_linear_solver(). False in one process.
struct BondsChoice {
  bool partitioned = false;
  int rings = 0;  ///< stencils around a rank's particles whose families it holds
  std::string reason;
};
BondsChoice partitioned_bonds(const Scene& scene, int ranks);

/// The families a rank with `rows` evaluates: its particles and those without a row, and every
/// particle within `rings` stencils of them (Model::family_held, from lattice offsets).
std::vector<char> families_to_hold(const Model& model, const OwnedRows& rows, int rings);

/// ProblemOptions::share_forces for a rank with `rows`: the forces of its particles, both
/// components, to every rank (an MPI_Allgatherv); those without a row stay as computed.
std::function<void(VectorXd&)> force_exchange(const OwnedRows& rows);
/// ProblemOptions::share_particle_values for a rank with `rows`: one value per particle, its
/// owner's to every rank; those without a row stay as computed.
std::function<void(VectorXd&)> particle_exchange(const OwnedRows& rows);

/// Each unknown's particle and direction, and the particles' positions (LinearSolver's hint).
UnknownLayout unknown_layout(const Model& model, Index n_unknowns);
/// Per unknown (in the order of `constraints.free_index`), the owner of its particle.
std::vector<int> unknown_owners(const Constraints& constraints, const std::vector<int>& particle_owner);

/// Whether each rank holds only its part of the model (solver.belos.model), and why. A part
/// runs Newton with belos (either tangent) and ADR under mpirun, with or without contact and
/// failure (docs/guide/distributed.md, "Running on the parts"). `auto` picks the part under
/// mpirun for a scene without contact, the whole model elsewhere; a one-process run with
/// another linear solver, or ADR, ignores the key. Call after resolve_linear_solver().
struct ModelChoice {
  bool part = false;
  std::string reason;
};
ModelChoice part_model_choice(const Scene& scene, int ranks);

/// This rank's part of the model (docs/guide/distributed.md, "The partitioned model"): the
/// owners by solver.belos.partition (owned_rows(), every particle owned), the whole model
/// discretised with only the families the part holds (one ring for the matrix-free tangent, two for the
/// assembled one), the part extracted from it and the whole model freed.
ModelPart part_model(const Scene& scene, int rank, int ranks);
/// The rings of families around its particles a part holds: one for Newton's matrix-free
/// tangent, two for an assembled tangent (belos's `assembled`, or ADR's for its density).
int part_rings(const Scene& scene);
/// ADR's share of the unknowns on a rank's part: the owned ones first, the ghost tail imported
/// from the owners by the problem's exchange.
UnknownShare part_unknown_share(const QuasiStaticProblem& problem, const ModelPart& part);
/// The problem's options on that part, under mpirun: its rows, the sums and maxima over the
/// ranks, the owned unknowns and the import of the ghost tail (collective: it builds a
/// parallel::PartExchange over the unknowns).
ProblemOptions part_problem_options(const Scene& scene, const ModelPart& part, int rank);
/// The layout of a rank's part of the model (collective under mpirun): the nodes numbered rank
/// by rank (each rank's own in the part's order, from the sum of the lower ranks' counts), its
/// ghosts' numbers asked of their owners (parallel::PartExchange), and the whole model's centre.
UnknownLayout part_unknown_layout(const ModelPart& part, int rank);

/// Under mpirun (problem.owned_rows() a part): the unknowns of this rank's particles, and the
/// MPI operations distributed ADR needs; empty in one process.
UnknownShare unknown_share(const QuasiStaticProblem& problem);

/// The step solver the scene asks for (Newton or ADR); `linear` receives Newton's linear
/// solver (it must outlive the step solver) and stays empty for ADR. With `part`, the problem
/// is built on that rank's part of the model (ProblemOptions::owned_unknowns): Newton with
/// belos only, its layout part_unknown_layout()'s (collective).
std::unique_ptr<StepSolver> make_step_solver(const Scene& scene, QuasiStaticProblem& problem,
                                             std::unique_ptr<LinearSolver>& linear,
                                             const ModelPart* part = nullptr);

}  // namespace peristat
