#include "app/setup.hpp"

#include <memory>
#include <stdexcept>

#include "app/linear_solvers.hpp"
#include "core/error.hpp"
#include "solvers/adr.hpp"
#include "solvers/newton.hpp"
#include "solvers/trilinos/parallel.hpp"
#include "solvers/trilinos/partition.hpp"

namespace peristat {

ProblemOptions problem_options(const Scene& scene, const RunPlan& plan) {
  ProblemOptions options;
  options.contact = scene.contact;
  options.failure = scene.failure;
  options.bond_preconditioner = plan.bond_preconditioner;
  options.surface_correction = scene.discretization.surface_correction;
  options.matrix_free = plan.matrix_free();
  return options;
}

ProblemOptions problem_options(const Scene& scene) { return problem_options(scene, scene_plan(scene, 1)); }

OwnedRows owned_rows(const Scene& scene, const Model& model, int rank, int ranks) {
  OwnedRows rows;
  if (ranks <= 1) return rows;
  rows.rank = rank;
  if (scene.solver.linear.belos.partition == BelosPartition::strips) {
    rows.owner = strip_owners(model.constraints, ranks);
    complete_owners(model, rows.owner);
    return rows;
  }
  // rcb: the nodes' positions, bisected; then the particles without an unknown, by proximity.
  const Constraints& cons = model.constraints;
  std::vector<double> x, y;
  std::vector<Index> node_particle;
  for (Index p = 0; p < model.particles.size(); ++p)
    if (cons.free_index[2 * p] >= 0 || cons.free_index[2 * p + 1] >= 0) {
      node_particle.push_back(p);
      x.push_back(model.particles.position[p].x());
      y.push_back(model.particles.position[p].y());
    }
  const std::vector<int> part = rcb_parts(x, y, ranks);
  rows.owner.assign(static_cast<std::size_t>(model.particles.size()), -1);
  for (std::size_t k = 0; k < node_particle.size(); ++k)
    rows.owner[static_cast<std::size_t>(node_particle[k])] = part[k];
  complete_owners(model, rows.owner);
  return rows;
}

std::vector<char> families_to_hold(const Model& model, const OwnedRows& rows, int rings) {
  std::vector<char> held(static_cast<std::size_t>(model.particles.size()), 0);
  for (std::size_t p = 0; p < held.size(); ++p) held[p] = rows.owner[p] == rows.rank || rows.owner[p] < 0;
  for (int ring = 0; ring < rings; ++ring) held = within_stencil(model, held);
  return held;
}

namespace {
/// Each entry's owner's value to every rank; entries without an owner stay as computed.
std::function<void(VectorXd&)> owned_entries_exchange(const std::vector<int>& owner) {
  auto exchange = std::make_shared<parallel::OwnedExchange>(owner, true);
  return [exchange](VectorXd& values) { exchange->share(values.data()); };
}
}  // namespace

std::function<void(VectorXd&)> particle_exchange(const OwnedRows& rows) { return owned_entries_exchange(rows.owner); }

std::function<void(VectorXd&)> force_exchange(const OwnedRows& rows) {
  std::vector<int> owner(2 * rows.owner.size());
  for (std::size_t p = 0; p < rows.owner.size(); ++p) owner[2 * p] = owner[2 * p + 1] = rows.owner[p];
  return owned_entries_exchange(owner);
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

std::vector<int> unknown_owners(const Constraints& constraints, const std::vector<int>& particle_owner) {
  std::vector<int> owner(static_cast<std::size_t>(constraints.n_free), -1);
  const std::vector<Index>& free = constraints.free_index;
  for (std::size_t c = 0; c < free.size(); ++c)
    if (free[c] >= 0) owner[static_cast<std::size_t>(free[c])] = particle_owner[c / 2];
  return owner;
}

ModelPart part_model(const Scene& scene, int rings, int rank, int ranks) {
  OwnedRows rows;
  const Model whole = discretise(scene, [&](const Model& unbonded) {
    rows = owned_rows(scene, unbonded, rank, ranks);
    if (rows.owner.empty())
      rows = OwnedRows{0, std::vector<int>(static_cast<std::size_t>(unbonded.particles.size()), 0)};
    return families_to_hold(unbonded, rows, rings);
  });
  return extract_part(whole, rows.owner, rank, whole.family_held);
}

ModelPart part_model(const Scene& scene, int rank, int ranks) {
  return part_model(scene, part_rings(make_run_plan(scene, ranks)), rank, ranks);
}

namespace {
/// One value per particle of a part from its owner into the ranks that read it (collective to
/// build and to call). Particles without an owner (no row, kept by every rank alike) keep their
/// values.
std::function<void(VectorXd&)> part_particle_exchange(const ModelPart& part) {
  std::vector<std::size_t> exchanged;
  std::vector<std::int64_t> ids;
  std::vector<int> owner;
  for (std::size_t p = 0; p < part.owner.size(); ++p)
    if (part.owner[p] >= 0) {
      exchanged.push_back(p);
      ids.push_back(part.global_id[p]);
      owner.push_back(part.owner[p]);
    }
  auto exchange =
      std::make_shared<parallel::PartExchange>(ids, owner, static_cast<std::size_t>(part.n_owned));
  auto scratch = std::make_shared<std::vector<double>>(exchanged.size());
  return [exchange, scratch, exchanged](VectorXd& values) {
    for (std::size_t k = 0; k < exchanged.size(); ++k)
      (*scratch)[k] = values[static_cast<Index>(exchanged[k])];
    exchange->share(scratch->data());
    for (std::size_t k = 0; k < exchanged.size(); ++k)
      values[static_cast<Index>(exchanged[k])] = (*scratch)[k];
  };
}
}  // namespace

ProblemOptions part_problem_options(const Scene& scene, const ModelPart& part, int rank) {
  return part_problem_options(scene, scene_plan(scene, parallel::size()), part, rank);
}

ProblemOptions part_problem_options(const Scene& scene, const RunPlan& plan, const ModelPart& part, int rank) {
  ProblemOptions options = problem_options(scene, plan);
  options.rows = OwnedRows{rank, part.owner};
  options.sum_over_ranks = [](double v) { return parallel::sum_over_ranks(v); };
  options.max_over_ranks = parallel::max_over_ranks;
  options.share_forces = [](VectorXd&) {};  // a part's own rows read no other rank's forces
  options.owned_unknowns = part.n_owned_unknowns;
  auto ghosts = std::make_shared<parallel::PartExchange>(part.global_unknown,
                                                         unknown_owners(part.model.constraints, part.owner),
                                                         static_cast<std::size_t>(part.n_owned_unknowns));
  options.import_ghosts = [ghosts](VectorXd& x) { ghosts->share(x.data()); };
  options.sum_in_rank_order = parallel::sum_in_rank_order;
  if (scene.failure.enabled) {
    options.share_particle_values = part_particle_exchange(part);  // the damage, the pieces' labels
    options.gather_over_ranks = parallel::gather_over_ranks;
    options.global_id = part.global_id;
    options.n_particles_whole = part.n_particles_whole;
    options.gather_on_root = parallel::gather_rows_on_root;
  }
  if (scene.contact.enabled) {
    ContactRanks& c = options.contact_ranks;
    c.global_id = part.global_id;
    c.counted.resize(part.owner.size());
    for (std::size_t p = 0; p < part.owner.size(); ++p) c.counted[p] = counted_by(part.owner[p], rank);
    c.n_particles_whole = part.n_particles_whole;
    c.gather = parallel::gather_over_ranks;
    c.gather_on_root = parallel::gather_rows_on_root;
  }
  return options;
}

UnknownLayout part_unknown_layout(const ModelPart& part, int rank) {
  const Model& m = part.model;
  UnknownLayout layout = unknown_layout(m, m.constraints.n_free);
  layout.owner = part.owner;
  const Index n = m.particles.size();
  const std::vector<Index>& free = m.constraints.free_index;
  const auto is_node = [&](Index p) { return free[2 * p] >= 0 || free[2 * p + 1] >= 0; };
  std::int64_t owned_nodes = 0;
  for (Index p = 0; p < part.n_owned; ++p) owned_nodes += is_node(p);
  layout.first_node = parallel::sum_over_lower_ranks(owned_nodes, &layout.global_nodes);
  // Every entry a double for the exchange: node numbers below 2^53 are exact. Particles without
  // an owner (no row, kept by every rank alike) are not exchanged: they hold no node.
  VectorXd node = VectorXd::Constant(n, -1.0);
  std::int64_t next = layout.first_node;
  for (Index p = 0; p < part.n_owned; ++p)
    if (is_node(p)) node[p] = static_cast<double>(next++);
  part_particle_exchange(part)(node);
  layout.global_node.assign(static_cast<std::size_t>(n), -1);
  for (Index p = 0; p < n; ++p)
    layout.global_node[static_cast<std::size_t>(p)] = static_cast<std::int64_t>(node[p]);
  // The whole model's centre: each particle counted by its owner (rank 0 those without one).
  double sums[3] = {0.0, 0.0, 0.0};
  for (Index p = 0; p < n; ++p) {
    const int o = part.owner[static_cast<std::size_t>(p)];
    if (counted_by(o, rank)) {
      sums[0] += m.particles.position[p].x();
      sums[1] += m.particles.position[p].y();
      sums[2] += 1.0;
    }
  }
  parallel::sum_in_rank_order(sums, 3);
  layout.centre_x = sums[0] / sums[2];
  layout.centre_y = sums[1] / sums[2];
  return layout;
}

UnknownShare part_unknown_share(const QuasiStaticProblem& problem, const ModelPart& part) {
  UnknownShare share;
  share.owned.assign(static_cast<std::size_t>(part.model.constraints.n_free), 0);
  std::fill_n(share.owned.begin(), part.n_owned_unknowns, char{1});
  share.sum = parallel::sum_in_rank_order;
  share.max = parallel::max_over_ranks;
  // The ghost tail from the owners, for x at the end of a solve and the pseudo-velocity at
  // each step, by the problem's own exchange (it imports x's tail at every evaluation).
  share.share = share.share_reads = [&problem](VectorXd& x) { problem.import_ghosts(x); };
  share.problem_imports_state = true;
  return share;
}

UnknownShare unknown_share(const QuasiStaticProblem& problem) {
  const OwnedRows& rows = problem.owned_rows();
  UnknownShare share;
  if (rows.all()) return share;
  const std::vector<int> owner = unknown_owners(problem.model().constraints, rows.owner);
  share.owned.resize(owner.size());
  for (std::size_t f = 0; f < owner.size(); ++f) share.owned[f] = owner[f] == rows.rank;
  share.sum = parallel::sum_in_rank_order;
  share.max = parallel::max_over_ranks;
  auto exchange = std::make_shared<parallel::OwnedExchange>(owner);  // throws for an unknown without owner
  share.share = [exchange](VectorXd& x) { exchange->share(x.data()); };
  // The ghosts, rebuilt (collectively: every rank sees the same contact version) when a
  // partner search changed the pairs.
  struct Ghosts {
    std::uint64_t version = 0;
    std::unique_ptr<parallel::GhostExchange> exchange;
  };
  auto ghosts = std::make_shared<Ghosts>();
  share.share_reads = [ghosts, owner, &problem](VectorXd& x) {
    if (!ghosts->exchange || ghosts->version != problem.structure_version()) {
      const std::vector<Index> reads = problem.residual_reads();
      ghosts->exchange = std::make_unique<parallel::GhostExchange>(
          owner, std::vector<long long>(reads.begin(), reads.end()));
      ghosts->version = problem.structure_version();
    }
    ghosts->exchange->share(x.data());
  };
  return share;
}

std::unique_ptr<StepSolver> make_step_solver(const Scene& scene, const RunPlan& plan, QuasiStaticProblem& problem,
                                             std::unique_ptr<LinearSolver>& linear, const ModelPart* part) {
  if (part && plan.newton() && plan.linear != LinearSolverKind::belos)
    throw std::logic_error("make_step_solver: a rank's part of the model runs Newton with belos or ADR");
  if (!plan.newton())
    return std::make_unique<AdrSolver>(problem, scene.solver.adr, problem.pseudo_velocity_input(),
                                       part ? part_unknown_share(problem, *part) : unknown_share(problem));
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
  return make_step_solver(scene, plan_with_linear(scene, parallel::size(), kind), problem, linear, part);
}

}  // namespace peristat
