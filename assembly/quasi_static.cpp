#include "assembly/quasi_static.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <stdexcept>
#include <string>

#include <omp.h>

#include "core/clock.hpp"
#include "core/huge_pages.hpp"
#include "materials/fragments.hpp"

namespace peristat {

namespace {
std::unique_ptr<ContactSystem> make_contact(const Model& model, const ProblemOptions& options, const Ranks& ranks,
                                            const GlobalIds& ids, double& seconds) {
  if (!options.contact.enabled) return nullptr;
  // On a part, its share of the pairs: the pairs that touch its own particles, by global id.
  ContactRanks share;
  if (!options.global_id.empty()) {
    share.ids = &ids;
    share.counted.resize(options.rows.owner.size());
    for (std::size_t p = 0; p < share.counted.size(); ++p)
      share.counted[p] = counted_by(options.rows.owner[p], options.rows.rank);
  }
  const double t0 = wall_seconds();
  auto contact = std::make_unique<ContactSystem>(model, options.contact, ranks, std::move(share));
  seconds = wall_seconds() - t0;
  return contact;
}

/// On a part: the families whose surface correction a rank counts in its stats, each
/// family on one rank (its owner's; those without a row on rank 0). Empty: every family.
std::vector<char> counted_families(const Model& model, const OwnedRows& rows) {
  if (model.holds_every_family()) return {};
  std::vector<char> counted(rows.owner.size(), 0);
  for (std::size_t p = 0; p < counted.size(); ++p) counted[p] = rows.counts(static_cast<Index>(p));
  return counted;
}

/// On a rank's part, its share of the failure decisions: it proposes the pairs of the families
/// it counts (its own; rank 0's also those without a row). A whole model numbers itself.
FailureRanks failure_ranks(const ProblemOptions& options, const RankExchanges& exchanges, const GlobalIds& ids) {
  if (options.global_id.empty()) return {};
  std::vector<char> proposes(options.rows.owner.size(), 0);
  for (std::size_t p = 0; p < proposes.size(); ++p) proposes[p] = options.rows.counts(static_cast<Index>(p));
  return {std::move(proposes), exchanges.particle_values(), &ids};
}

/// A part's particles by global id (ProblemOptions::global_id), with the map back, built once
/// for contact and failure; none for a whole model (they number it by itself).
GlobalIds global_ids(const ProblemOptions& options) {
  if (options.global_id.empty() || !(options.contact.enabled || options.failure.enabled)) return {};
  return GlobalIds(options.global_id, options.n_particles_whole);
}

/// Per body, its material's kernel.
std::vector<std::unique_ptr<FamilyKernel>> make_kernels(const Model& model) {
  std::vector<std::unique_ptr<FamilyKernel>> kernels;
  for (const BodyInfo& body : model.bodies) kernels.push_back(make_family_kernel(body.material));
  return kernels;
}

/// Every kernel's tangent is constant (linearised kinematics).
bool constant_tangents(const std::vector<std::unique_ptr<FamilyKernel>>& kernels) {
  bool constant = true;
  for (const auto& kernel : kernels) constant = constant && kernel->constant_tangent();
  return constant;
}

}  // namespace

QuasiStaticProblem::QuasiStaticProblem(const Model& model, const ProblemOptions& options, const Ranks& ranks)
    : m_model(model),
      m_options(options),
      m_ranks(ranks),
      m_exchanges(model,
                  RankLayout{m_options.rows, m_options.owned_unknowns, m_options.global_id, m_options.global_unknown},
                  options.failure.enabled, ranks),
      m_ids(global_ids(options)),
      m_contact(make_contact(model, options, ranks, m_ids, m_timings.contact_setup)),
      m_failure(options.failure.enabled ? std::make_unique<BondFailure>(model, options.failure, ranks,
                                                                        failure_ranks(options, m_exchanges, m_ids))
                                        : nullptr),
      m_pattern(options.matrix_free
                    ? TangentPattern{}
                    : build_pattern(model, PatternReach::two_horizons, 0.0, m_contact.get(), options.rows)),
      m_kernels(make_kernels(model)),
      m_small_kinematics(constant_tangents(m_kernels)),
      m_correction(model, options.surface_correction, counted_families(model, options.rows)),
      m_balance(model, m_kernels, m_contact != nullptr, m_small_kinematics, m_options, ranks),
      m_damage(model, m_failure.get(), m_options, ranks),
      m_fragments(model, m_failure.get(), m_options, ranks, m_exchanges.particle_values()),
      m_action(model, options.matrix_free) {
  const Index n = model.particles.size();
  const Bonds& bonds = model.bonds;
  const std::size_t nbonds = bonds.neighbour.size();
  // The per-bond state, the largest arrays of a run, goes on huge pages (core/huge_pages.hpp).
  // The bonds' relative displacements: kept for the failure criterion only; the families
  // use a per-thread scratch of the largest family's size.
  if (m_failure) assign_huge(m_eta, nbonds, Vec2(Vec2::Zero()));
  for (Index i = 0; i < n; ++i) m_largest_family = std::max(m_largest_family, bonds.family_size(i));
  m_eta_scratch.assign(static_cast<std::size_t>(omp_get_max_threads()) * m_largest_family, Vec2::Zero());
  m_extension_scratch.assign(m_eta_scratch.size(), 0.0);
  m_force_scratch.assign(m_eta_scratch.size(), Vec2::Zero());
  m_law.assign(n, BondForceLaw{});
  for (const auto& kernel : m_kernels) m_finite.push_back(kernel->finite_kinematics() ? 1 : 0);
  if (options.float_factors && !options.matrix_free)
    throw std::logic_error("QuasiStaticProblem: float factors are the matrix-free action's");
  if (options.float_factors) {
    m_s_scratch.assign(m_eta_scratch.size(), Vec2::Zero());
    m_kbond_scratch.assign(m_eta_scratch.size(), BondStiffness{});
  }
  restore_action_storage();
  // The kept factors' product is the bond forces themselves where the forces are linear in u
  // and the product is exact to double rounding and covers every row (linear_forces()).
  m_linear_forces_allowed =
      options.matrix_free && m_small_kinematics && !options.float_factors && options.rows.whole();
  m_s_self.assign(n, Vec2::Zero());
  m_beta_volume.assign(n, 0.0);
  if (options.float_copy && (!options.matrix_free || options.float_factors))
    throw std::logic_error("QuasiStaticProblem: a float copy is of the matrix-free action's double factors");
  m_action.set_float_copy(options.float_copy);
  m_u = VectorXd::Zero(2 * n);
  m_force = VectorXd::Zero(2 * n);
  if (m_failure && model.constraints.has_images()) {
    m_mirror_zone.assign(n, 0);
    for (const MirrorImage& im : model.constraints.images) m_mirror_zone[im.ghost] = m_mirror_zone[im.source] = 1;
  }
  // What a rank computes with own rows only, from the rows alone: built here, once.
  if (options.rows.all() && ranks.size() > 1)
    throw std::logic_error("QuasiStaticProblem: a whole model is one process's, not one of " +
                           std::to_string(ranks.size()) + " ranks'");
  if (!options.rows.all() && options.global_id.empty())
    throw std::logic_error("QuasiStaticProblem: a rank of a distributed run holds its part of the model "
                           "(ProblemOptions::global_id)");
  // What this rank computes (every family and force of a whole model), from the rows alone.
  m_share = RankShare(model, options.rows);
  if (!model.holds_every_family()) check_partition();
}

void QuasiStaticProblem::check_partition() const {
  // A part holds the families its rows read (docs/guide/distributed.md): the residual and the
  // matrix-free action read the families of the rank's particles and their neighbours; an
  // assembled tangent (and ADR's density from it) reads a column's families two horizons from
  // its rows, so then the neighbours of those are held too.
  if (m_options.global_id.empty())
    throw std::logic_error("QuasiStaticProblem: a model holding some families only must be a rank's part");
  const Bonds& bonds = m_model.bonds;
  const std::vector<char>& held = m_model.family_held;
  for (std::size_t i = 0; i < held.size(); ++i) {
    if (!m_share.family_needed(static_cast<Index>(i))) continue;
    if (!held[i])
      throw std::logic_error("QuasiStaticProblem: the family of particle " + std::to_string(i) +
                             " is needed by this rank's rows and not held by its model");
    if (!m_options.matrix_free)
      for (Index b = bonds.start[i]; b < bonds.start[i + 1]; ++b)
        if (!held[static_cast<std::size_t>(bonds.neighbour[b])])
          throw std::logic_error("QuasiStaticProblem: an assembled tangent reads the family of particle " +
                                 std::to_string(bonds.neighbour[b]) +
                                 ", which this rank's model does not hold");
  }
}

Vec2 QuasiStaticProblem::reaction(std::size_t k) const {
  Vec2 f = Vec2::Zero();
  // The forces are right at a rank's own particles (and at those without an owner, which rank
  // 0 counts; every particle in one process): their sum, summed over the ranks.
  const OwnedRows& rows = m_options.rows;
  for (const Index d : m_model.constraints.condition_dofs.at(k))
    if (rows.counts(d / 2)) f[d % 2] += m_force[d];
  std::array<double, 2> sums = {f.x(), f.y()};
  m_ranks.sum_in_rank_order(sums);
  return Vec2(sums[0], sums[1]);
}

Mat2 QuasiStaticProblem::stress(Index i) {
  ensure_laws();
  const Bonds& bonds = m_model.bonds;
  const bool finite = m_finite[static_cast<std::size_t>(m_model.particles.body[i])];
  const std::span<const double> w = m_correction.family_weights(i);
  Mat2 P = Mat2::Zero();
  for (Index b = bonds.start[i]; b < bonds.start[i + 1]; ++b) {
    const Vec2 xi = m_model.xi(i, b);
    const BondKinematics k = bond_kinematics(finite, xi, bond_displacement(i, b));
    P += (m_law[i].t(w[b - bonds.start[i]], k.x, k.e) * k.M) * xi.transpose();
  }
  return P;
}

void QuasiStaticProblem::set_load_factor(double lambda) {
  m_lambda = lambda;
  if (m_contact) m_contact->start_trial(m_committed_lambda > 0.0 ? lambda / m_committed_lambda : 1.0);
}

ConstraintUpdate QuasiStaticProblem::update_multipliers(const VectorXd& x) {
  if (!m_contact) return {};
  expand_state(x);
  const MultiplierUpdate m =
      m_contact->update_multipliers(m_u, m_failure ? m_failure->weights() : std::span<const double>());
  ConstraintUpdate out;
  out.violation = m.violation;
  out.updates = m.updates;
  switch (m.status) {
    case MultiplierUpdate::Status::satisfied:
      out.status = ConstraintUpdate::Status::satisfied;
      break;
    case MultiplierUpdate::Status::updated:
      out.status = ConstraintUpdate::Status::updated;
      break;
    case MultiplierUpdate::Status::exhausted: {
      out.status = ConstraintUpdate::Status::exhausted;
      char buf[480];
      std::snprintf(buf, sizeof buf,
                    "exact contact: %s %.3g of pair (%ld, %ld) still above contact.closure_tolerance "
                    "after %d multiplier updates (contact.max_multiplier_updates); more updates, a larger "
                    "tolerance or contact.enforcement: penalty (the paper's law, without multipliers) may get past it",
                    m.kind, m.violation, static_cast<long>(m.pair_i), static_cast<long>(m.pair_j), m.updates);
      out.message = buf;
      break;
    }
  }
  return out;
}

std::string QuasiStaticProblem::check_converged_state(const VectorXd& x) {
  m_balance.discard();
  char buf[400];
  if (m_contact) {
    expand_state(x);
    if (const double slide = m_contact->slide_since_search(m_u); slide > m_contact->max_slide_between_searches()) {
      std::snprintf(buf, sizeof buf,
                    "the contact faces slid %.3g dx since the last partner search, more than a search covers "
                    "(%.3g dx): a partner may have been missed",
                    slide / m_model.spacing, m_contact->max_slide_between_searches() / m_model.spacing);
      return buf;
    }
    if (const CrossedPair c = m_contact->first_crossed_pair(m_u); c.any()) {
      std::snprintf(
          buf, sizeof buf,
          "contact pair (%ld, %ld) has crossed: particle %ld (reference (%.6g, %.6g) m) passed particle "
          "%ld (reference (%.6g, %.6g) m) along the interface normal, n.Y = %.3g dx",
          static_cast<long>(c.i), static_cast<long>(c.j), static_cast<long>(c.j), c.Xj.x(), c.Xj.y(),
          static_cast<long>(c.i), c.Xi.x(), c.Xi.y(), c.normal / m_model.spacing);
      return buf;
    }
    // On a part: every partner a search could find must be held by the part of the rank that
    // owns the face particle. No smaller increment helps once the faces slid that far: the
    // parts must grow (PartsOutgrown carries, per rank, the particles within two search radii,
    // so that the grown parts follow the faces for a while).
    const double radius = m_contact->search_radius();
    if (const std::int64_t outside =
            !m_contact->holds_every_particle()
                ? m_ranks.sum(static_cast<std::int64_t>(m_contact->partners_not_held(m_u, radius).size()))
                : 0;
        outside > 0) {
      std::vector<std::int64_t> grow = m_contact->partners_not_held(m_u, 2.0 * radius);
      const std::int64_t total = m_ranks.sum(static_cast<std::int64_t>(grow.size()));
      std::snprintf(buf, sizeof buf,
                    "the contact faces slid past the ranks' parts of the model: %ld face particles have a "
                    "partner within the search radius that their rank does not hold",
                    static_cast<long>(outside));
      throw PartsOutgrown(buf, std::move(grow), total);
    }
  }
  if (std::string why = m_damage.check(); !why.empty()) return why;
  return measure_increment(x, true);
}

std::string QuasiStaticProblem::measure_increment(const VectorXd& x, bool check) {
  // The last evaluate was at x: m_u, m_force (bonds + contact) and m_energy are x's.
  ensure_laws();
  if (m_balance.begin_increment(m_u, m_force, m_contact.get(), m_energy)) {
    // Simpson's rule: the bond forces at the midpoint. The midpoint's families write m_law,
    // m_energy and (swapped in) a force vector of their own; x's are kept aside and put back,
    // the same bits an evaluation at x would make again (the contact pairs stay x's: the
    // families do not touch them), for a fraction of its time (one family pass less).
    const std::vector<BondForceLaw> law = m_law;
    const double energy = m_energy;
    VectorXd midpoint_force(m_force.size());
    m_force.swap(midpoint_force);
    m_balance.midpoint(m_u);
    bond_forces(false);
    m_balance.midpoint_forces(m_force);
    m_force.swap(midpoint_force);
    m_law = law;
    m_energy = energy;
    expand_state(x);
  }
  return m_balance.finish_increment(check);
}

std::vector<std::string> QuasiStaticProblem::state_checks() const {
  std::vector<std::string> checks = Problem::state_checks();
  if (m_contact) {
    checks.emplace_back("no crossed contact pair");
    checks.emplace_back("contact slide since the partner search within its reach");
    if (!m_contact->holds_every_particle())
      checks.emplace_back("every partner of a face particle held by its rank's part");
  }
  if (m_failure) checks.emplace_back("damage never decreasing");
  checks.emplace_back(m_small_kinematics ? "energy balance of the bonds (trapezoid rule, exact for linearised kinematics)"
                                         : "energy balance of the bonds (Simpson's rule with the midpoint forces)");
  return checks;
}

void QuasiStaticProblem::commit(const VectorXd& x) {
  // Elastic bonds carry no history; a round of breaking becomes permanent, friction slip
  // and contact multipliers are updated; the energy ledger moves on to x.
  if (!m_balance.pending()) {  // a caller that did not check x: measure without checking
    evaluate(x, m_scratch, nullptr);
    measure_increment(x, false);
  }
  m_balance.commit();
  m_damage.commit();
  m_committed_lambda = m_lambda;
  if (m_failure) m_failure->commit();
  if (!m_contact) return;
  expand_state(x);
  const std::uint64_t version = m_contact->version();
  m_contact->commit(m_u);
  if (m_contact->version() != version) {  // new partners: the pattern grows
    if (!m_options.matrix_free)
      m_pattern = build_pattern(m_model, PatternReach::two_horizons, 0.0, m_contact.get(), m_options.rows);
    m_preconditioner.reset();
  }
}

void QuasiStaticProblem::save_state(StateArchive& archive) const {
  archive.put("problem/load_factor", m_committed_lambda);
  m_balance.save(archive);
  if (m_failure) m_failure->save(archive);
  if (m_contact) m_contact->save(archive);
}

void QuasiStaticProblem::restore_state(const StateArchive& archive, const VectorXd& x) {
  const double lambda = archive.scalar("problem/load_factor");
  m_balance.restore(archive);
  if (m_failure) {
    // The families holding a broken bond get their influence factors again (each family's
    // factors depend on its own bonds only, so the order of the rounds does not matter).
    collect_changed_families(m_failure->restore(archive));
    if (!m_changed_families.empty()) m_correction.update(m_failure->weights(), m_changed_families);
  }
  if (m_contact) {
    m_contact->restore(archive);
    if (!m_options.matrix_free)
      m_pattern = build_pattern(m_model, PatternReach::two_horizons, 0.0, m_contact.get(), m_options.rows);
    m_preconditioner.reset();
  }
  m_fragments.update(m_contact.get());
  set_load_factor(lambda);
  m_committed_lambda = lambda;
  if (m_contact) m_contact->start_trial(1.0);
  // The ledger's accepted state: x's displacement and forces (the increment measured from
  // the fresh problem's zero state is discarded).
  evaluate(x, m_scratch, nullptr);
  measure_increment(x, false);
  m_balance.accept_state();
  m_damage.commit();
}

ProblemTraits QuasiStaticProblem::traits() const {
  ProblemTraits traits;
  traits.tangent_symmetric = !m_contact || m_contact->symmetric();
  traits.tangent_constant = m_small_kinematics && !m_contact && !m_failure;
  traits.structure_version = m_contact ? m_contact->version() : 0;
  traits.state_signature = m_contact ? m_contact->signature() : 0;
  // Every rank breaks the same pairs (bond_failure.hpp), so the count is collective too.
  const auto broken = static_cast<std::uint64_t>(m_failure ? m_failure->broken() : 0);
  traits.preconditioner_state = traits.state_signature ^ (broken * 0x9E3779B97F4A7C15ULL);
  return traits;
}

void QuasiStaticProblem::evaluate(const VectorXd& x, VectorXd& r, SparseMatrix* K) {
  m_balance.discard();  // a check measured an earlier evaluation
  ++m_evaluations;
  // With linearised kinematics the families' factors s_b, k_b (and the pairs' stiffnesses made
  // of them) depend on the bonds alone: a tangent evaluation at the bonds of the last one keeps
  // them, bit for bit what the kernel would write again.
  const bool factors_kept = K && factors_current();
  const bool patch = K && !factors_kept && can_patch_factors();
  if (K) {
    m_tangent_evaluation = m_evaluations;
    m_tangent_broken = m_failure ? m_failure->broken() : 0;
    if (m_action_suspended) restore_action_storage();
  } else if (m_tangent_evaluation == m_evaluations - 1 && m_options.matrix_free &&
             m_model.bonds.neighbour.size() >= m_suspend_bonds) {
    keep_tangent_state();  // before m_u moves on (suspend_action())
  }
  expand_state(x);
  if (m_own_rows_only && K)
    throw std::logic_error("QuasiStaticProblem::evaluate: own rows only, with a tangent");
  // Patched factors: the forces still from the families' kernels, as making the factors
  // would give them, so that the run's path is the same bits either way.
  if (patch) patch_factors();
  if ((!K || factors_kept) && linear_forces()) {
    m_action.bond_forces(hessians(), m_options.rows, m_u, m_force);
    m_laws_current = false;
    ++m_linear_force_evaluations;
  } else {
    bond_forces(K != nullptr && !factors_kept && !patch);
    m_laws_current = true;  // the kernels' laws and energy at m_u: ensure_laws() has nothing to do
  }
  if (m_contact) {
    const double t0 = wall_seconds();
    m_contact->evaluate(m_u, K != nullptr);
    m_contact->add_internal_force(m_force);
    m_timings.contact += wall_seconds() - t0;
  }
  m_force_scale = force_norm();
  m_fragments.hold(m_force);
  m_model.constraints.gather(m_force, r);
  if (m_own_rows_only)
    for (const Index f : m_share.other_unknowns()) r[f] = 0.0;
  if (K && m_options.matrix_free) {
    m_action.prepare(hessians(), m_contact.get(), !m_fragments.unknowns().empty(), !factors_kept && !patch);
    m_factors_version = m_bonds_version;
    if (!factors_kept && !patch) {
      ++m_factor_evaluations;
      m_dirty_families.clear();
    }
  } else if (K) {
    gather_tangent(*K);
    m_fragments.decouple(*K);
  }
}

void QuasiStaticProblem::expand_state(const VectorXd& x) {
  if (!m_exchanges.ghosts()) return expand(x, m_u);
  m_x_ghosts = x;  // the same size every time: the storage stays
  m_exchanges.ghosts()->share(m_x_ghosts.data());
  expand(m_x_ghosts, m_u);
}

UnknownSpace QuasiStaticProblem::unknowns() const {
  const Index n = m_model.constraints.n_free;
  // A whole model owns every unknown; a part its first owned_unknowns.
  return UnknownSpace(n, m_options.owned_unknowns >= 0 ? m_options.owned_unknowns : n, m_ranks);
}

double QuasiStaticProblem::force_norm() const {
  // Each rank's own particles (every one of a whole model), summed over the ranks, and the
  // particles without a row (every rank computes those alike), added once.
  const OwnedRows& rows = m_options.rows;
  double own = 0.0, unowned = 0.0;
  for (Index q = 0; q < m_model.particles.size(); ++q) {
    const double f2 = m_force[2 * q] * m_force[2 * q] + m_force[2 * q + 1] * m_force[2 * q + 1];
    if (rows.contains(q))
      own += f2;
    else if (rows.computes(q))  // no owner
      unowned += f2;
  }
  return std::sqrt(m_ranks.sum(own) + unowned);
}

bool QuasiStaticProblem::set_evaluation_mode(EvaluationMode mode) {
  if (mode == EvaluationMode::touching_closed && !m_contact) return false;
  if (m_contact) m_contact->set_touching_closed(mode == EvaluationMode::touching_closed);
  m_own_rows_only = mode == EvaluationMode::own_rows_only;
  return true;
}

void QuasiStaticProblem::add_stiffness_bound(VectorXd& row_sums) const {
  if (!m_contact) return;
  const std::vector<Index>& free = m_model.constraints.free_index;
  for (Index k = 0; k < m_contact->size(); ++k) {
    const ContactPair& c = m_contact->pairs()[k];
    const double b = 4.0 * m_contact->stiffness_bound(k);
    for (Index p : {c.i, c.j})
      for (int d = 0; d < 2; ++d)
        if (const Index f = free[2 * p + d]; f >= 0) row_sums[f] += b;
  }
}

void QuasiStaticProblem::set_velocity(const VectorXd& v) {
  if (!m_contact || !m_contact->wants_velocity()) return;
  m_model.constraints.scatter(v, m_velocity);
  m_contact->set_velocity(m_velocity);
}

Index QuasiStaticProblem::advance_irreversible_state(const VectorXd& x, Index at_most) {
  if (!m_failure) return 0;
  expand_state(x);
  const Index n = m_model.particles.size();
#pragma omp parallel for schedule(static)
  for (Index i = 0; i < n; ++i) family_displacements(i, m_eta.data() + m_model.bonds.start[i]);
  const std::vector<std::pair<Index, Index>>& broken = m_failure->break_over_criterion(m_eta, at_most);
  // Every rank's count (on a part `broken` holds only the pairs it holds a direction of), so
  // that the collective steps below are taken by every rank or none.
  const Index count = m_failure->round_pairs();
  if (count == 0) return 0;
  check_mirror_zone(broken);
  collect_changed_families(broken);
  if (!m_changed_families.empty()) m_correction.update(m_failure->weights(), m_changed_families);
  // The new faces are contact candidates at once (when the scene models contact).
  if (m_contact) m_contact->add_broken_bonds(broken, m_u);
  m_balance.set_bonds_changed(true);
  m_fragments.update_after_round(m_contact.get(), broken);
  return count;
}

void QuasiStaticProblem::check_mirror_zone(const std::vector<std::pair<Index, Index>>& broken) {
  std::vector<double> found;  // the bond's ends (collective: a part without mirror images takes part)
  for (const auto& [i, j] : broken) {
    if (m_mirror_zone.empty()) break;
    if (!m_mirror_zone[i] && !m_mirror_zone[j]) continue;
    const Vec2 &a = m_model.particles.position[i], &b = m_model.particles.position[j];
    found = {a.x(), a.y(), b.x(), b.y()};
    break;
  }
  // On a part, each rank sees the pairs it holds: the first rank's bond that found one.
  const std::vector<double> all = m_ranks.all_gather(found);  // the ends' positions
  found.assign(all.begin(), all.begin() + std::min<std::ptrdiff_t>(4, static_cast<std::ptrdiff_t>(all.size())));
  if (found.empty()) return;
  m_failure->revert();
  char buf[256];
  std::snprintf(buf, sizeof buf,
                "the bond (%.6g, %.6g)-(%.6g, %.6g) reached the failure criterion within the reflected "
                "depth of a mirror edge, where the mirror layers cannot follow broken bonds; move the "
                "mirror edge further from where the body breaks",
                found[0], found[1], found[2], found[3]);
  throw ModelLimit(buf);
}

void QuasiStaticProblem::revert_irreversible_state() {
  if (!m_failure) return;
  m_balance.set_bonds_changed(false);
  collect_changed_families(m_failure->last_round());
  m_failure->revert();
  if (!m_changed_families.empty()) m_correction.update(m_failure->weights(), m_changed_families);
  if (m_contact) {
    m_contact->drop_last_round();
    m_contact->start_trial(1.0);  // the failed re-solve's multipliers go too
  }
  m_fragments.update(m_contact.get());
}

void QuasiStaticProblem::collect_changed_families(const std::vector<std::pair<Index, Index>>& pairs) {
  ++m_bonds_version;  // every change of the bonds passes here (a round, its undoing, a restore)
  m_changed_families.clear();
  for (const auto& [i, j] : pairs) {
    m_changed_families.push_back(i);
    m_changed_families.push_back(j);
  }
  std::sort(m_changed_families.begin(), m_changed_families.end());
  m_changed_families.erase(std::unique(m_changed_families.begin(), m_changed_families.end()),
                           m_changed_families.end());
  if (m_options.matrix_free && m_small_kinematics)  // the only factors kept across changes (patch_factors())
    m_dirty_families.insert(m_dirty_families.end(), m_changed_families.begin(), m_changed_families.end());
}

std::size_t QuasiStaticProblem::memory_bytes() const {
  auto bytes = [](const auto& v) { return v.capacity() * sizeof(v[0]); };
  std::size_t total =
      m_correction.memory_bytes() + bytes(m_changed_families) + bytes(m_eta) + bytes(m_eta_scratch) +
      bytes(m_extension_scratch) + bytes(m_force_scratch) + bytes(m_law) + bytes(m_s) + bytes(m_kbond) +
      bytes(m_s32) + bytes(m_kbond32) + bytes(m_s_scratch) + bytes(m_kbond_scratch) + bytes(m_s_self) +
      bytes(m_beta_volume) +
      static_cast<std::size_t>(m_u.size() + m_u_tangent.size() + m_force.size() + m_velocity.size()) *
          sizeof(double) +
      m_pattern.memory_bytes() + m_ids.memory_bytes() + m_share.memory_bytes() + m_balance.memory_bytes() +
      m_damage.memory_bytes() + m_fragments.memory_bytes() + m_action.memory_bytes();
  if (m_failure) total += m_failure->memory_bytes();
  if (m_preconditioner) total += m_preconditioner->memory_bytes();
  if (m_contact) total += m_contact->memory_bytes();
  return total;
}

}  // namespace peristat
