#include "app/setup.hpp"

#include <array>
#include <memory>
#include <stdexcept>

#include "app/linear_solvers.hpp"
#include "core/error.hpp"
#include "solvers/adr.hpp"
#include "solvers/newton.hpp"
#include "app/unknown_share.hpp"
#include "parallel/exchange.hpp"

namespace peristat {

ProblemOptions problem_options(const Scene& scene, const RunPlan& plan) {
  ProblemOptions options;
  options.contact = scene.contact;
  options.failure = scene.failure;
  options.bond_preconditioner = plan.bond_preconditioner;
  options.surface_correction = scene.discretization.surface_correction;
  options.matrix_free = plan.matrix_free();
  options.float_factors = plan.float_factors;
  options.float_copy = plan.float_copy;
  return options;
}

ProblemOptions problem_options(const Scene& scene) { return problem_options(scene, scene_plan(scene, 1)); }

OwnedRows owned_rows(const Scene& scene, const Model& model, int rank, int ranks) {
  OwnedRows rows;
  if (ranks <= 1) return rows;
  rows.rank = rank;
  const LatticeCensus census = take_census(scene, false);
  const LatticePartition partition(census, ranks, scene.solver.linear.belos.partition);
  rows.owner.reserve(model.particles.lattice.size());
  for (const auto& l : model.particles.lattice) rows.owner.push_back(partition.owner(l[0], l[1]));
  return rows;
}

std::vector<char> families_to_hold(const Model& model, const OwnedRows& rows, int rings) {
  std::vector<char> held(static_cast<std::size_t>(model.particles.size()), 0);
  for (std::size_t p = 0; p < held.size(); ++p) held[p] = rows.owner[p] == rows.rank || rows.owner[p] < 0;
  for (int ring = 0; ring < rings; ++ring) held = within_stencil(model, held);
  return held;
}

UnknownLayout unknown_layout(const Model& model, Index n_unknowns) {
  const std::vector<Index>& free = model.constraints.free_index;
  UnknownLayout layout;
  layout.component.resize(n_unknowns);
  for (Index c = 0; c < static_cast<Index>(free.size()); ++c)
    if (free[c] >= 0) layout.component[free[c]] = c;
  layout.x.reserve(model.particles.size());
  layout.y.reserve(model.particles.size());
  for (const Vec2& X : model.particles.position) {
    layout.x.push_back(X.x());
    layout.y.push_back(X.y());
  }
  return layout;
}

ModelPart part_model(const Scene& scene, int rings, int rank, int ranks, const std::vector<std::int64_t>& extra) {
  const LatticeCensus census = take_census(scene, true);
  const LatticePartition partition(census, std::max(ranks, 1), scene.solver.linear.belos.partition);
  return build_part(scene, census, partition, rank, rings, extra);
}

ModelPart part_model(const Scene& scene, int rank, int ranks) {
  return part_model(scene, part_rings(make_run_plan(scene, ranks)), rank, ranks);
}

void set_part(ProblemOptions& options, const ModelPart& part, int rank) {
  options.rows = OwnedRows{rank, part.owner};
  options.owned_unknowns = part.n_owned_unknowns;
  options.global_id = part.global_id;
  options.global_unknown = part.global_unknown;
  options.n_particles_whole = part.n_particles_whole;
}

ProblemOptions part_problem_options(const Scene& scene, const RunPlan& plan, const ModelPart& part, int rank) {
  ProblemOptions options = problem_options(scene, plan);
  set_part(options, part, rank);
  return options;
}

UnknownLayout part_unknown_layout(const ModelPart& part, const Ranks& ranks) {
  const int rank = ranks.rank();
  const Model& m = part.model;
  UnknownLayout layout = unknown_layout(m, m.constraints.n_free);
  layout.owner = part.owner;
  const Index n = m.particles.size();
  const std::vector<Index>& free = m.constraints.free_index;
  const auto is_node = [&](Index p) { return free[2 * p] >= 0 || free[2 * p + 1] >= 0; };
  std::int64_t owned_nodes = 0;
  for (Index p = 0; p < part.n_owned; ++p) owned_nodes += is_node(p);
  layout.first_node = ranks.sum_over_lower_ranks(owned_nodes, &layout.global_nodes);
  // Each node's number from its owner. Particles without an owner (no row, kept by every rank
  // alike) are not exchanged: they hold no node.
  layout.global_node.assign(static_cast<std::size_t>(n), -1);
  std::int64_t next = layout.first_node;
  for (Index p = 0; p < part.n_owned; ++p)
    if (is_node(p)) layout.global_node[static_cast<std::size_t>(p)] = next++;
  OwnedEntriesExchange(ranks, part.global_id, part.owner, static_cast<std::size_t>(part.n_owned))
      .share(layout.global_node.data());
  // The whole model's centre: each particle counted by its owner (rank 0 those without one).
  std::array<double, 3> sums = {0.0, 0.0, 0.0};
  for (Index p = 0; p < n; ++p) {
    const int o = part.owner[static_cast<std::size_t>(p)];
    if (counted_by(o, rank)) {
      sums[0] += m.particles.position[p].x();
      sums[1] += m.particles.position[p].y();
      sums[2] += 1.0;
    }
  }
  ranks.sum_in_rank_order(sums);
  layout.centre_x = sums[0] / sums[2];
  layout.centre_y = sums[1] / sums[2];
  return layout;
}

std::unique_ptr<StepSolver> make_step_solver(const Scene& scene, const RunPlan& plan, QuasiStaticProblem& problem,
                                             std::unique_ptr<LinearSolver>& linear, const ModelPart* part) {
  if (part && part->n_particles_whole != part->model.particles.size() && plan.newton() &&
      plan.linear != LinearSolverKind::belos)
    throw std::logic_error("make_step_solver: a rank's part of the model runs Newton with belos or ADR");
  if (!plan.newton())
    return std::make_unique<AdrSolver>(problem, scene.solver.adr, problem.pseudo_velocity_input(),
                                       part ? part_unknown_share(problem, *part) : UnknownShare{});
  if (plan.matrix_free() != problem.matrix_free())
    throw std::logic_error("make_step_solver: solver.linear matrix_free needs a problem built with "
                           "ProblemOptions::matrix_free (problem_options() of the same plan)");
  LinearOptions options = scene.solver.linear;
  options.type = plan.linear;
  linear = make_problem_linear_solver(scene, problem, options, part);
  return std::make_unique<NewtonSolver>(problem, *linear, scene.solver.newton);
}

std::unique_ptr<StepSolver> make_step_solver(const Scene& scene, QuasiStaticProblem& problem,
                                             std::unique_ptr<LinearSolver>& linear, const ModelPart* part) {
  LinearSolverKind kind = scene.solver.linear.type;
  if (scene.solver.type == SolverKind::newton && kind == LinearSolverKind::automatic) {
    kind = choose_linear_solver(scene, static_cast<double>(problem.n_unknowns()), 1).kind;
    // The problem was built before the choice: with its tangent assembled, the same method on it.
    if (kind == LinearSolverKind::matrix_free && !problem.matrix_free()) kind = LinearSolverKind::cg;
  }
  return make_step_solver(scene, plan_with_linear(scene, problem.ranks().size(), kind), problem, linear, part);
}

}  // namespace peristat
