#include "assembly/quasi_static.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <stdexcept>
#include <string>

#include <omp.h>

#include "assembly/column_writer.hpp"
#include "core/clock.hpp"
#include "core/huge_pages.hpp"
#include "materials/fragments.hpp"

namespace peristat {

namespace {
/// Damage is a ratio of sums of weights: a value below the accepted one by more than this is
/// a healed bond, not round-off.
constexpr double kDamageRoundOff = 1e-12;
/// The energy balance of an increment without breaking holds to this fraction of the energy
/// scale (measured: below 1e-9 on the cases, round-off of sums over every family).
constexpr double kEnergyTolerance = 1e-6;
/// Forces that vanish up to round-off (a rigid motion) do work of about 1e-16 E V per
/// spacing moved; 1e-14 leaves a margin of 100.
constexpr double kRoundOffWork = 1e-14;

std::unique_ptr<ContactSystem> make_contact(const Model& model, const ContactOptions& options,
                                            const ContactRanks& ranks, double& seconds) {
  if (!options.enabled) return nullptr;
  const double t0 = wall_seconds();
  auto contact = std::make_unique<ContactSystem>(model, options, ranks);
  seconds = wall_seconds() - t0;
  return contact;
}

/// The free unknowns (ascending) of the particles `read` marks, with the sources of the mirror
/// ghosts among them (a ghost's displacement is its source's image).
std::vector<Index> read_unknowns(const Constraints& cons, std::vector<char>& read) {
  for (const MirrorImage& im : cons.images)
    if (read[static_cast<std::size_t>(im.ghost)]) read[static_cast<std::size_t>(im.source)] = 1;
  std::vector<Index> unknowns;
  for (std::size_t p = 0; p < read.size(); ++p)
    if (read[p])
      for (std::size_t c = 0; c < 2; ++c)
        if (const Index f = cons.free_index[2 * p + c]; f >= 0) unknowns.push_back(f);
  return unknowns;  // ascending: particles in order, and a particle's two unknowns in order
}

/// Partitioned bonds: the families whose surface correction a rank counts in its stats, each
/// family on one rank (its owner's; those without a row on rank 0). Empty: every family.
std::vector<char> counted_families(const Model& model, const OwnedRows& rows) {
  if (model.holds_every_family()) return {};
  std::vector<char> counted(rows.owner.size(), 0);
  for (std::size_t p = 0; p < counted.size(); ++p) counted[p] = rows.counts(static_cast<Index>(p));
  return counted;
}

/// With partitioned bonds, the rank's share of the failure decisions: it proposes the pairs
/// of the families it counts (its own; rank 0's also those without a row).
FailureRanks failure_ranks(const Model& model, const ProblemOptions& options) {
  if (model.holds_every_family()) return {};
  return {counted_families(model, options.rows),
          options.gather_over_ranks,
          options.share_particle_values,
          options.owned_unknowns >= 0 ? options.global_id : std::vector<std::int64_t>{},
          options.n_particles_whole,
          options.gather_on_root};
}

}  // namespace

QuasiStaticProblem::QuasiStaticProblem(const Model& model, const ProblemOptions& options)
    : m_model(model),
      m_options(options),
      m_contact(make_contact(model, options.contact, options.contact_ranks, m_contact_setup_seconds)),
      m_failure(options.failure.enabled
                    ? std::make_unique<BondFailure>(model, options.failure, failure_ranks(model, options))
                    : nullptr),
      m_pattern(options.matrix_free
                    ? TangentPattern{}
                    : build_pattern(model, PatternReach::two_horizons, 0.0, m_contact.get(), options.rows)),
      m_correction(model, options.surface_correction, counted_families(model, options.rows)) {
  m_small_kinematics = true;
  for (const BodyInfo& body : model.bodies) {
    m_kernels.push_back(make_family_kernel(body.material));
    m_small_kinematics = m_small_kinematics && m_kernels.back()->constant_tangent();
  }
  const Index n = model.particles.size();
  const Bonds& bonds = model.bonds;
  const std::size_t nbonds = bonds.neighbour.size();
  // The per-bond state, the largest arrays of a run, goes on huge pages (core/huge_pages.hpp).
  // The bonds' relative displacements: kept for the failure criterion only; the families
  // use a per-thread scratch of the largest family's size.
  if (m_failure) assign_huge(m_eta, nbonds, Vec2(Vec2::Zero()));
  for (Index i = 0; i < n; ++i) m_largest_family = std::max(m_largest_family, bonds.family_size(i));
  m_eta_scratch.assign(static_cast<std::size_t>(omp_get_max_threads()) * m_largest_family, Vec2::Zero());
  assign_huge(m_direction, nbonds, Vec2(Vec2::Zero()));
  assign_huge(m_s, nbonds, Vec2(Vec2::Zero()));
  assign_huge(m_t, nbonds, 0.0);
  assign_huge(m_kbond, nbonds, Sym2{});
  // apply_tangent()'s chunks: at least 1024 particles, about 128 of them, a function of the
  // particle count alone (the sums' order must not depend on the threads or ranks).
  if (options.matrix_free) m_colours = chunk_colours(model, m_chunk = std::max<Index>(1024, n / 128));
  m_s_self.assign(n, Vec2::Zero());
  m_beta_volume.assign(n, 0.0);
  m_u = VectorXd::Zero(2 * n);
  m_force = VectorXd::Zero(2 * n);
  // The ledger starts from the undeformed, unloaded state: no force, no energy.
  m_u_accepted = m_fbond_accepted = VectorXd::Zero(2 * n);
  if (m_contact) m_fcontact_accepted = VectorXd::Zero(2 * n);
  if (m_failure) {
    m_damage_accepted = VectorXd::Zero(n);
    if (m_failure->partitioned())
      m_graph_parts = std::make_unique<GraphParts>(
          GraphParts{m_failure->ranks().proposes, m_options.gather_over_ranks, m_failure->ranks().global_id,
                     m_failure->part() ? std::span<const int>(m_options.rows.owner) : std::span<const int>{},
                     m_options.share_particle_values});
    find_unsupported(model, m_failure->weights(), m_initially_unsupported, m_component, m_graph_parts.get());
    m_fragment.assign(n, 0);
  }
  for (Index i = 0; i < n; ++i)
    if (!part() || options.rows.contains(i))  // a part: its own particles, summed over the ranks
      m_energy_unit += model.particles.volume[i] * model.bodies[model.particles.body[i]].material.E;
  m_energy_unit = over_ranks(m_energy_unit);
  if (m_failure && model.constraints.has_images()) {
    m_mirror_zone.assign(n, 0);
    for (const MirrorImage& im : model.constraints.images) m_mirror_zone[im.ghost] = m_mirror_zone[im.source] = 1;
  }
  if (partitioned()) check_partition();
}

void QuasiStaticProblem::check_partition() const {
  // What the partitioned path supports (docs/guide/distributed.md, "Partitioned bonds"): forces
  // shared after each whole evaluation; with failure, the collectives of its decisions. The residual and the
  // matrix-free action read the families of the rank's particles and their neighbours; an assembled tangent
  // (and ADR's density from it) reads a column's families two horizons from its rows, so then the neighbours
  // of those are held too.
  if (!distributed() || !m_options.share_forces ||
      (m_failure && (!m_options.gather_over_ranks || !m_options.share_particle_values)))
    throw std::logic_error(
        "QuasiStaticProblem: partitioned bonds need a distributed problem and a force exchange (and, with "
        "failure, a gather and a particle exchange)");
  const_cast<QuasiStaticProblem*>(this)->build_own_masks();
  const Bonds& bonds = m_model.bonds;
  const std::vector<char>& held = m_model.family_held;
  for (std::size_t i = 0; i < held.size(); ++i) {
    if (!m_family_needed[i]) continue;
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
  if (!part()) {
    for (const Index d : m_model.constraints.condition_dofs.at(k)) f[d % 2] += m_force[d];
    return f;
  }
  // A part's forces are right at its own particles (and those without an owner, which rank 0
  // counts): their sum, summed over the ranks.
  const OwnedRows& rows = m_options.rows;
  for (const Index d : m_model.constraints.condition_dofs.at(k))
    if (rows.counts(d / 2)) f[d % 2] += m_force[d];
  double sums[2] = {f.x(), f.y()};
  m_options.sum_in_rank_order(sums, 2);
  return Vec2(sums[0], sums[1]);
}

Mat2 QuasiStaticProblem::stress(Index i) const {
  const Bonds& bonds = m_model.bonds;
  Mat2 P = Mat2::Zero();
  for (Index b = bonds.start[i]; b < bonds.start[i + 1]; ++b)
    P += m_t[b] * m_direction[b] * bonds.xi[b].transpose();
  return P;
}

void QuasiStaticProblem::set_load_factor(double lambda) {
  m_lambda = lambda;
  if (m_contact) m_contact->start_trial(m_committed_lambda > 0.0 ? lambda / m_committed_lambda : 1.0);
}

ConstraintUpdate QuasiStaticProblem::update_multipliers(const VectorXd& x) {
  if (!m_contact) return {};
  expand_state(x);
  const MultiplierUpdate m = m_contact->update_multipliers(m_u);
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
      char buf[320];
      std::snprintf(buf, sizeof buf,
                    "exact contact: closure %.3g of pair (%ld, %ld) still above contact.closure_tolerance "
                    "after %d multiplier updates (contact.max_multiplier_updates)",
                    m.violation, static_cast<long>(m.pair_i), static_cast<long>(m.pair_j), m.updates);
      out.message = buf;
      break;
    }
  }
  return out;
}

std::string QuasiStaticProblem::check_converged_state(const VectorXd& x) {
  m_pending = false;
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
    // owns the face particle. No smaller increment helps once the faces slid that far.
    if (const std::int64_t outside = m_contact->partners_outside(m_u); outside > 0) {
      std::snprintf(
          buf, sizeof buf,
          "the contact faces slid past the ranks' parts of the model: %ld face particles have a partner "
          "within the search radius that their rank does not hold; solver.belos.model=whole runs this "
          "scene",
          static_cast<long>(outside));
      throw ModelLimit(buf);
    }
  }
  if (std::string why = check_damage(); !why.empty()) return why;
  return measure_increment(x, true);
}

std::string QuasiStaticProblem::check_damage() {
  if (!m_failure) return {};
  m_failure->damage(m_damage_now);
  // The first particle whose damage decreased: (its whole model's index, position, before,
  // after); on a part, each rank's own particles, the smallest index over the ranks.
  std::vector<double> found;
  for (Index i = 0; i < m_damage_now.size(); ++i) {
    if (part() && !m_options.rows.counts(i)) continue;
    if (m_damage_now[i] >= m_damage_accepted[i] - kDamageRoundOff) continue;
    const Vec2& X = m_model.particles.position[i];
    found = {static_cast<double>(m_failure->global(i)), X.x(), X.y(), m_damage_accepted[i], m_damage_now[i]};
    break;
  }
  if (part()) {
    const std::vector<double> all = m_options.gather_over_ranks(found);
    found.clear();
    for (std::size_t at = 0; at < all.size(); at += 5)
      if (found.empty() || all[at] < found[0])
        found.assign(all.begin() + static_cast<std::ptrdiff_t>(at),
                     all.begin() + static_cast<std::ptrdiff_t>(at + 5));
  }
  if (found.empty()) return {};
  char buf[320];
  std::snprintf(
      buf, sizeof buf,
      "the damage of particle %ld at (%.6g, %.6g) m decreased from %.6g to %.6g: broken bonds healed",
      static_cast<long>(found[0]), found[1], found[2], found[3], found[4]);
  return buf;
}

std::string QuasiStaticProblem::measure_increment(const VectorXd& x, bool check) {
  // The last evaluate was at x: m_u, m_force (bonds + contact) and m_energy are x's.
  const Index n2 = m_u.size();
  m_u_next = m_u;
  m_fbond_next = m_force;
  if (m_contact) {
    m_fcontact_next.setZero(n2);
    m_contact->add_internal_force(m_fcontact_next);
    m_fbond_next -= m_fcontact_next;
  }
  const double energy_next = m_energy;
  EnergyLedger& L = m_pending_ledger;
  L = m_ledger;
  L.strain_energy = energy_next;
  const std::vector<Index>& free = m_model.constraints.free_index;
  // On a part, each rank's particles' work (the ghosts' forces are zero here), summed over the ranks.
  double work[4] = {0.0, 0.0, 0.0, 0.0};  // bonds, contact, on the unknowns, on the prescribed components
  for (Index d = 0; d < n2; ++d) {
    const double du = m_u_next[d] - m_u_accepted[d];
    const double fb = 0.5 * (m_fbond_accepted[d] + m_fbond_next[d]);
    const double fc = m_fcontact_accepted.size() ? 0.5 * (m_fcontact_accepted[d] + m_fcontact_next[d]) : 0.0;
    work[0] += fb * du;
    work[1] += fc * du;
    work[free[d] >= 0 ? 2 : 3] += (fb + fc) * du;
  }
  for (double& w : work) w = over_ranks(w);
  const double bond_work = work[0];
  L.contact_work += work[1];
  L.residual_work += work[2];
  L.external_work += work[3];
  const double change = energy_next - m_ledger.strain_energy;
  std::string why;
  if (m_bonds_changed) {
    L.released += bond_work - change;
  } else {
    // The rule's work of the bond forces: the trapezoid is exact for the quadratic energy of
    // linearised kinematics; finite kinematics use Simpson's rule with the bond forces at the
    // midpoint (one more evaluation of the families, then x's again).
    double rule = bond_work;
    if (!m_small_kinematics) {
      m_u = 0.5 * (m_u_accepted + m_u_next);
      bond_forces(false);
      rule = 0.0;
      for (Index d = 0; d < n2; ++d)
        rule += (m_fbond_accepted[d] + 4.0 * m_force[d] + m_fbond_next[d]) * (m_u_next[d] - m_u_accepted[d]);
      rule = over_ranks(rule) / 6.0;
      evaluate(x, m_scratch, nullptr);
    }
    L.quadrature += bond_work - change;
    // The tolerance: a fraction of the energy scale; the round-off of forces that are zero up
    // to round-off doing work over a large motion (rigid motion); and for Simpson's rule a
    // tenth of its distance from the trapezoid's (an estimate of the trapezoid's error, of
    // which Simpson's is a higher order: measured 1e-4 of it for 3% stretch + 5% shear in one step).
    double max_du = 0.0;
    for (Index d = 0; d < n2; ++d) max_du = std::max(max_du, std::abs(m_u_next[d] - m_u_accepted[d]));
    if (part()) max_du = m_options.max_over_ranks(max_du);
    const double scale = std::max({std::abs(energy_next), std::abs(m_ledger.strain_energy), std::abs(bond_work)});
    const double tolerance = kEnergyTolerance * scale + 0.1 * std::abs(rule - bond_work) +
                             kRoundOffWork * m_energy_unit * std::max(1.0, max_du / m_model.spacing);
    const double relative = std::abs(rule - change) / std::max(scale, std::numeric_limits<double>::min());
    L.worst_relative = std::max(L.worst_relative, relative);
    ++L.checked;
    if (check && !(std::abs(rule - change) <= tolerance)) {
      char buf[400];
      std::snprintf(buf, sizeof buf,
                    "energy balance: the bonds' stored energy changed by %.6e J over the increment, the work of "
                    "their forces was %.6e J (difference %.2e J, tolerance %.2e J): the bond forces are not the "
                    "derivative of the stored energy",
                    change, rule, std::abs(rule - change), tolerance);
      why = buf;
    }
  }
  m_pending = why.empty();
  return why;
}

std::vector<std::string> QuasiStaticProblem::state_checks() const {
  std::vector<std::string> checks = Problem::state_checks();
  if (m_contact) {
    checks.emplace_back("no crossed contact pair");
    checks.emplace_back("contact slide since the partner search within its reach");
    if (m_contact->partitioned())
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
  if (!m_pending) {  // a caller that did not check x: measure without checking
    evaluate(x, m_scratch, nullptr);
    measure_increment(x, false);
  }
  m_ledger = m_pending_ledger;
  m_pending = m_bonds_changed = false;
  m_u_accepted.swap(m_u_next);
  m_fbond_accepted.swap(m_fbond_next);
  if (m_contact) m_fcontact_accepted.swap(m_fcontact_next);
  if (m_failure) {
    m_failure->damage(m_damage_now);
    m_damage_accepted.swap(m_damage_now);
  }
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
  const EnergyLedger& e = m_ledger;
  archive.put("problem/energy_ledger", {e.external_work, e.residual_work, e.strain_energy, e.contact_work, e.released,
                                        e.quadrature, e.worst_relative, static_cast<double>(e.checked)});
  if (m_failure) m_failure->save(archive);
  if (m_contact) m_contact->save(archive);
}

void QuasiStaticProblem::restore_state(const StateArchive& archive, const VectorXd& x) {
  const double lambda = archive.scalar("problem/load_factor");
  const std::vector<double>& e = archive.get("problem/energy_ledger", 8);
  m_ledger = EnergyLedger{e[0], e[1], e[2], e[3], e[4], e[5], e[6], static_cast<Index>(e[7])};
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
  update_fragments();
  set_load_factor(lambda);
  m_committed_lambda = lambda;
  if (m_contact) m_contact->start_trial(1.0);
  // The ledger's accepted state: x's displacement and forces (the increment measured from
  // the fresh problem's zero state is discarded).
  evaluate(x, m_scratch, nullptr);
  measure_increment(x, false);
  m_pending = m_bonds_changed = false;
  m_u_accepted.swap(m_u_next);
  m_fbond_accepted.swap(m_fbond_next);
  if (m_contact) m_fcontact_accepted.swap(m_fcontact_next);
  if (m_failure) m_failure->damage(m_damage_accepted);
}

std::uint64_t QuasiStaticProblem::preconditioner_state() const {
  // Every rank breaks the same pairs (bond_failure.hpp), so the count is collective too.
  const auto broken = static_cast<std::uint64_t>(m_failure ? m_failure->broken() : 0);
  return state_signature() ^ (broken * 0x9E3779B97F4A7C15ULL);
}

void QuasiStaticProblem::evaluate(const VectorXd& x, VectorXd& r, SparseMatrix* K) {
  m_pending = false;  // a check measured an earlier evaluation
  expand_state(x);
  if (m_own_rows_only && K)
    throw std::logic_error("QuasiStaticProblem::evaluate: own rows only, with a tangent");
  bond_forces(K != nullptr);
  if (m_contact) {
    const double t0 = wall_seconds();
    m_contact->evaluate(m_u, K != nullptr);
    m_contact->add_internal_force(m_force);
    m_contact_seconds += wall_seconds() - t0;
  }
  m_force_scale = force_norm();
  Vec2 reaction = Vec2::Zero();  // bonds inside a fragment cancel: what remains is contact
  for (const Index c : m_fragment_components) {
    if (!part() || m_options.rows.counts(c / 2)) reaction[c % 2] += m_force[c];
    m_force[c] = 0.0;
  }
  // On a part: the sum over the ranks' own particles (collective: every rank knows that
  // fragments exist).
  if (part() && m_fragment_particles > 0) m_options.sum_in_rank_order(reaction.data(), 2);
  m_fragment_reaction = reaction.norm();
  m_model.constraints.gather(m_force, r);
  if (m_own_rows_only)
    for (const Index f : m_other_unknowns) r[f] = 0.0;
  if (K && m_options.matrix_free) {
    pair_stiffness();
    if (m_contact) {
      m_pair_jacobian.resize(static_cast<std::size_t>(m_contact->size()));
      for (Index k = 0; k < m_contact->size(); ++k) m_pair_jacobian[k] = m_contact->jacobian(k);
    }
    m_fragment_diagonal = m_fragment_unknowns.empty() ? 0.0 : tangent_diagonal_max();
  } else if (K) {
    gather_tangent(*K);
    decouple_fragments(*K);
  }
}

// Family i writes rows i and its neighbours, whose lattice points lie within the stencil's
// reach of i's (checked here), so two chunks whose lattice boxes are more than two reaches
// apart along x or y write disjoint rows. Greedy colouring in chunk order.
std::vector<std::vector<Index>> chunk_colours(const Model& model, Index chunk) {
  const Particles& part = model.particles;
  const Bonds& bonds = model.bonds;
  const int reach = model.stencil.reach;
  const Index n = part.size();
  for (Index i = 0; i < n; ++i)
    for (Index b = bonds.start[i]; b < bonds.start[i + 1]; ++b)
      for (int d = 0; d < 2; ++d)
        if (std::abs(part.lattice[bonds.neighbour[b]][d] - part.lattice[i][d]) > reach)
          throw std::logic_error("chunk_colours: a bond longer than the stencil's reach");
  const Index chunks = (n + chunk - 1) / chunk;
  struct Box {
    std::array<int, 2> lo{std::numeric_limits<int>::max(), std::numeric_limits<int>::max()};
    std::array<int, 2> hi{std::numeric_limits<int>::min(), std::numeric_limits<int>::min()};
  };
  std::vector<Box> box(static_cast<std::size_t>(chunks));
  for (Index i = 0; i < n; ++i) {
    Box& x = box[static_cast<std::size_t>(i / chunk)];
    for (int d = 0; d < 2; ++d) {
      x.lo[d] = std::min(x.lo[d], part.lattice[i][d]);
      x.hi[d] = std::max(x.hi[d], part.lattice[i][d]);
    }
  }
  const auto apart = [&](const Box& a, const Box& b) {
    for (int d = 0; d < 2; ++d)
      if (a.lo[d] - b.hi[d] > 2 * reach || b.lo[d] - a.hi[d] > 2 * reach) return true;
    return false;
  };
  std::vector<int> colour(static_cast<std::size_t>(chunks), -1);
  std::vector<std::vector<Index>> colours;
  std::vector<char> taken;
  for (Index c = 0; c < chunks; ++c) {
    taken.assign(colours.size() + 1, 0);
    for (Index o = 0; o < c; ++o)
      if (!apart(box[static_cast<std::size_t>(c)], box[static_cast<std::size_t>(o)]))
        taken[static_cast<std::size_t>(colour[static_cast<std::size_t>(o)])] = 1;
    const auto k = static_cast<std::size_t>(std::find(taken.begin(), taken.end(), 0) - taken.begin());
    if (k == colours.size()) colours.emplace_back();
    colours[k].push_back(c);
    colour[static_cast<std::size_t>(c)] = static_cast<int>(k);
  }
  return colours;
}

void QuasiStaticProblem::set_action_chunk(Index chunk) {
  if (!m_options.matrix_free) throw std::logic_error("set_action_chunk: the problem is not matrix-free");
  m_colours = chunk_colours(m_model, m_chunk = std::max<Index>(1, chunk));
}

void QuasiStaticProblem::apply_tangent(const VectorXd& v, VectorXd& y) {
  // K v = gather(H scatter(v)): H the Hessian over every component, its family blocks
  // V_i sum_b B_b^T k_b B_b + beta_i V_i g_i g_i^T (g_i . w = s_self_i . w_i + sum_b s_b . w_j),
  // plus J_e (w_q - w_other) for the contact pairs; scatter() puts sign * v on mirror ghosts
  // (the assembled path's column folds), gather() keeps the unknowns' rows.
  const Bonds& bonds = m_model.bonds;
  const Particles& part = m_model.particles;
  const Index n = part.size();
  if (m_colours.empty() && n > 0)
    throw std::logic_error("apply_tangent: the problem was not built matrix-free");
  m_v_free = v;
  for (const Index f : m_fragment_unknowns) m_v_free[f] = 0.0;  // decoupled: no column
  m_model.constraints.scatter(m_v_free, m_v_full);
  m_y_full.setZero(2 * n);
  // Distributed: this rank's rows only, from the families they read (as the own-rows residual).
  const bool own = distributed();
  if (own) build_own_masks();
  // Raw pointers: the writes into y would otherwise make the compiler reload every vector's
  // data pointer after each bond.
  const Index* __restrict start = bonds.start.data();
  const Index* __restrict nbr = bonds.neighbour.data();
  const auto* __restrict s = reinterpret_cast<const double*>(m_s.data());  // Vec2: two packed doubles
  const auto* __restrict k = reinterpret_cast<const double*>(m_kbond.data());
  const auto* __restrict s_self = reinterpret_cast<const double*>(m_s_self.data());
  const double* __restrict beta_volume = m_beta_volume.data();
  const double* __restrict w = m_v_full.data();
  double* __restrict yf = m_y_full.data();
  static_assert(sizeof(Vec2) == 2 * sizeof(double) && sizeof(Sym2) == 3 * sizeof(double));
  // One pass over the families, each family's bond data read once from memory and used while
  // it is in cache: the dilatation rate G_i = beta_i V_i g_i . w, then G_i s_self_i into row i
  // and G_i s_b into row j for each bond b = i -> j (the column form of beta_i V_i g_i g_i^T),
  // and row i's pair stiffnesses k_b (w_i - w_j) (pair_stiffness()) and contact pairs.
  const auto family = [&](Index i) {
    const double wx = w[2 * i], wy = w[2 * i + 1];
    const Index b0 = start[i], b1 = start[i + 1];
    const bool needed = !own || m_family_needed[static_cast<std::size_t>(i)];
    const bool row = !own || m_options.rows.contains(i);  // else another rank's row, or one of no unknown
    double G = 0.0;
    if (needed) {
      double g = s_self[2 * i] * wx + s_self[2 * i + 1] * wy;
      for (Index b = b0; b < b1; ++b) g += s[2 * b] * w[2 * nbr[b]] + s[2 * b + 1] * w[2 * nbr[b] + 1];
      G = beta_volume[i] * g;
    }
    double yx = G * s_self[2 * i], yy = G * s_self[2 * i + 1];
    if (row) {
      for (Index b = b0; b < b1; ++b) {
        const Index j = nbr[b];
        yf[2 * j] += G * s[2 * b];
        yf[2 * j + 1] += G * s[2 * b + 1];
        const double dx = wx - w[2 * j], dy = wy - w[2 * j + 1];
        yx += k[3 * b] * dx + k[3 * b + 1] * dy;
        yy += k[3 * b + 1] * dx + k[3 * b + 2] * dy;
      }
      if (m_contact)
        for (auto e = m_contact->incident_begin(i); e != m_contact->incident_end(i); ++e)
          if (e->pair < static_cast<Index>(m_pair_jacobian.size())) {  // pairs added since: none yet
            const Vec2 f = m_pair_jacobian[e->pair] * Vec2(wx - w[2 * e->other], wy - w[2 * e->other + 1]);
            yx += f.x();
            yy += f.y();
          }
    } else if (needed) {
      for (Index b = b0; b < b1; ++b) {
        yf[2 * nbr[b]] += G * s[2 * b];
        yf[2 * nbr[b] + 1] += G * s[2 * b + 1];
      }
    }
    yf[2 * i] += yx;
    yf[2 * i + 1] += yy;
  };
  // Chunks of a colour write disjoint rows (chunk_colours()): they run in parallel, colour by
  // colour. Each row sums its terms in an order fixed by the particles alone.
#pragma omp parallel
  for (const std::vector<Index>& colour : m_colours) {
    const auto count = static_cast<Index>(colour.size());
#pragma omp for schedule(dynamic, 1)
    for (Index c = 0; c < count; ++c) {
      const Index begin = colour[static_cast<std::size_t>(c)] * m_chunk, end = std::min(begin + m_chunk, n);
      for (Index i = begin; i < end; ++i) family(i);
    }
  }
  if (own)
    for (Index q = 0; q < n; ++q)
      if (!m_options.rows.contains(q)) m_y_full[2 * q] = m_y_full[2 * q + 1] = 0.0;
  m_model.constraints.gather(m_y_full, y);
  for (const Index f : m_fragment_unknowns) y[f] = m_fragment_diagonal * v[f];
  if (own)
    for (const Index f : m_other_unknowns) y[f] = 0.0;
}

void QuasiStaticProblem::pair_stiffness() {
  const Bonds& bonds = m_model.bonds;
  const Particles& part = m_model.particles;
  const Index n = part.size();
  // Each pair {b, r} once, by the family of its lower bond index: no two iterations write
  // the same bond.
#pragma omp parallel for schedule(static)
  for (Index q = 0; q < n; ++q)
    for (Index b = bonds.start[q]; b < bonds.start[q + 1]; ++b) {
      const Index r = bonds.reverse[b];
      if (r < b) continue;
      const double Vq = part.volume[q], Vj = part.volume[bonds.neighbour[b]];
      const Sym2 &kb = m_kbond[b], &kr = m_kbond[r];
      const Sym2 k{Vq * kb[0] + Vj * kr[0], Vq * kb[1] + Vj * kr[1], Vq * kb[2] + Vj * kr[2]};
      m_kbond[b] = m_kbond[r] = k;
    }
}

double QuasiStaticProblem::tangent_diagonal_max() const {
  const Bonds& bonds = m_model.bonds;
  const Particles& part = m_model.particles;
  const std::vector<Index>& free = m_model.constraints.free_index;
  double largest = 0.0;
  for (Index q = 0; q < part.size(); ++q) {
    Vec2 d(m_beta_volume[q] * m_s_self[q].x() * m_s_self[q].x(), m_beta_volume[q] * m_s_self[q].y() * m_s_self[q].y());
    for (Index b = bonds.start[q]; b < bonds.start[q + 1]; ++b) {  // pair_stiffness()'s data
      const Index r = bonds.reverse[b];  // -1: the neighbour's family is another rank's
      const Vec2 sr = r >= 0 ? m_s[r] : Vec2::Zero();
      const double bVj = m_beta_volume[bonds.neighbour[b]];
      d.x() += m_kbond[b][0] + bVj * sr.x() * sr.x();
      d.y() += m_kbond[b][2] + bVj * sr.y() * sr.y();
    }
    if (m_contact)
      for (auto e = m_contact->incident_begin(q); e != m_contact->incident_end(q); ++e) {
        d.x() += m_pair_jacobian[e->pair](0, 0);
        d.y() += m_pair_jacobian[e->pair](1, 1);
      }
    for (int c = 0; c < 2; ++c)
      if (free[2 * q + c] >= 0) largest = std::max(largest, std::abs(d[c]));
  }
  return largest;
}

void QuasiStaticProblem::update_fragments() {
  if (!m_failure) return;
  find_unsupported(m_model, m_failure->weights(), m_unsupported, m_component, m_graph_parts.get());
  const Index n = m_model.particles.size();
  const std::vector<Index>& free = m_model.constraints.free_index;
  m_fragment_unknowns.clear();
  m_fragment_unknown.assign(static_cast<std::size_t>(m_model.constraints.n_free), 0);
  m_fragment_components.clear();
  m_fragment_particles = 0;
  std::vector<Index> roots;
  for (Index i = 0; i < n; ++i) {
    m_fragment[i] = m_unsupported[i] && !m_initially_unsupported[i];
    if (!m_fragment[i]) continue;
    if (!part() || m_options.rows.counts(i)) {  // on a part, its own particles (summed below)
      ++m_fragment_particles;
      roots.push_back(m_component[i]);
    }
    for (int d = 0; d < 2; ++d) {
      m_fragment_components.push_back(2 * i + d);
      if (free[2 * i + d] >= 0) {
        m_fragment_unknowns.push_back(free[2 * i + d]);
        m_fragment_unknown[free[2 * i + d]] = 1;
      }
    }
  }
  std::sort(roots.begin(), roots.end());
  roots.erase(std::unique(roots.begin(), roots.end()), roots.end());
  if (part()) {  // the components by global id: every rank's own particles' components, once
    const std::vector<double> all =
        m_options.gather_over_ranks(std::vector<double>(roots.begin(), roots.end()));
    std::vector<double> every = all;
    std::sort(every.begin(), every.end());
    m_fragments = static_cast<Index>(std::unique(every.begin(), every.end()) - every.begin());
    m_fragment_particles =
        static_cast<Index>(std::llround(over_ranks(static_cast<double>(m_fragment_particles))));
  } else {
    m_fragments = static_cast<Index>(roots.size());
  }
  if (m_contact) m_contact->set_excluded(m_fragment_particles > 0 ? m_fragment : std::vector<char>{});
}

Index QuasiStaticProblem::fragment_contacts() const {
  if (!m_contact || m_fragment_particles == 0) return 0;
  Index n = 0;
  for (std::size_t c = 0; c < m_fragment_components.size(); c += 2) {
    const Index i = m_fragment_components[c] / 2;
    if (part() && !m_options.rows.counts(i)) continue;  // a part: its own particles, summed over the ranks
    for (auto* e = m_contact->incident_begin(i); e != m_contact->incident_end(i); ++e)
      if (!m_fragment[e->other] && m_contact->result(e->pair).status != PairStatus::open) ++n;
  }
  return static_cast<Index>(std::llround(over_ranks(static_cast<double>(n))));
}

void QuasiStaticProblem::decouple_fragments(SparseMatrix& K) const {
  if (m_fragment_unknowns.empty()) return;
  // A rank's K holds its own rows only: the largest diagonal is the ranks' (the same number
  // on every rank, as in one process).
  double d = K.diagonal().cwiseAbs().maxCoeff();
  if (m_options.max_over_ranks) d = m_options.max_over_ranks(d);
  // The fragments' rows and columns zero, their diagonal d. Every stored entry is visited: a
  // rank's K holds row f only in the columns of f's couplings, which column f (holding the
  // rank's rows only) does not list.
  const std::vector<char>& fragment = m_fragment_unknown;
#pragma omp parallel for schedule(static)
  for (Index col = 0; col < static_cast<Index>(K.outerSize()); ++col)
    for (SparseMatrix::InnerIterator it(K, col); it; ++it)
      if (fragment[col] || fragment[it.row()]) it.valueRef() = it.row() == col ? d : 0.0;
}

void QuasiStaticProblem::family_displacements(Index i, Vec2* eta) const {
  const Bonds& bonds = m_model.bonds;
  const Vec2 ui(m_u[2 * i], m_u[2 * i + 1]);
  for (Index b = bonds.start[i]; b < bonds.start[i + 1]; ++b) {
    const Index j = bonds.neighbour[b];
    eta[b - bonds.start[i]] = Vec2(m_u[2 * j], m_u[2 * j + 1]) - ui;
  }
}

void QuasiStaticProblem::compute_families(bool want_tangent) {
  const Bonds& bonds = m_model.bonds;
  const Particles& p = m_model.particles;
  const Index n = p.size();
  // Partitioned: the energy of the rank's own families and of those without a row (which every
  // rank computes), to be summed over the ranks once each; a neighbour's family counts on its
  // owner.
  double energy = 0.0, own_energy = 0.0, unowned_energy = 0.0;
  // (Own rows only: the rank's rows of a distributed ADR step, no energy and no exchange.)
  const bool restrict = restricted(), split = partitioned() && !m_own_rows_only;
  const std::vector<int>& owner = m_options.rows.owner;
  const int rank = m_options.rows.rank;
  const std::size_t scratch = static_cast<std::size_t>(omp_get_max_threads()) * m_largest_family;
  if (m_eta_scratch.size() < scratch) m_eta_scratch.resize(scratch);  // more threads than at the start
#pragma omp parallel reduction(+ : energy, own_energy, unowned_energy)
  {
    Vec2* eta = m_eta_scratch.data() + static_cast<std::size_t>(omp_get_thread_num()) * m_largest_family;
#pragma omp for schedule(static)
    for (Index i = 0; i < n; ++i) {
      if (restrict && !m_family_needed[static_cast<std::size_t>(i)]) continue;
      const Index b0 = bonds.start[i], nb = bonds.family_size(i);
      family_displacements(i, eta);
      const FamilyOutputs out{std::span(m_t).subspan(b0, nb), std::span(m_direction).subspan(b0, nb),
                              std::span(m_s).subspan(b0, nb), std::span(m_kbond).subspan(b0, nb)};
      const FamilyResult res = m_kernels[p.body[i]]->evaluate(
          m_correction.weighted_volume()[i], std::span(bonds.xi).subspan(b0, nb),
          m_correction.weights().subspan(b0, nb), std::span<const Vec2>(eta, static_cast<std::size_t>(nb)), out,
          want_tangent);
      const double e = p.volume[i] * res.energy_density;
      energy += e;
      if (split) {
        const int o = owner[static_cast<std::size_t>(i)];
        if (o == rank)
          own_energy += e;
        else if (o < 0)
          unowned_energy += e;
      }
      if (want_tangent) {
        Vec2 s = Vec2::Zero();
        for (Index b = b0; b < b0 + nb; ++b) s -= m_s[b];
        m_s_self[i] = s;
        m_beta_volume[i] = res.beta * p.volume[i];
      }
    }
  }
  // Own rows only: a part of the families, not the energy of the model.
  // (Those without a row count on rank 0, inside the sum: every rank gets the same bits, whatever
  // its thread count, so that the energy check decides alike on every rank.)
  if (split)
    m_energy = m_options.sum_over_ranks(own_energy + (rank == 0 ? unowned_energy : 0.0));
  else
    m_energy = m_own_rows_only ? std::numeric_limits<double>::quiet_NaN() : energy;
}

void QuasiStaticProblem::bond_forces(bool want_tangent) {
  compute_families(want_tangent);
  gather_forces();
  if (partitioned() && !m_own_rows_only) m_options.share_forces(m_force);
}

void QuasiStaticProblem::gather_forces() {
  // dPi/du_q = -V_q sum_b t_b M_b (own family) + sum_b V_j t_r M_r (families of neighbours,
  // r the reverse bond j -> q).
  const Bonds& bonds = m_model.bonds;
  const Particles& p = m_model.particles;
  const Index n = p.size();
  const bool restrict = restricted();
#pragma omp parallel for schedule(static)
  for (Index q = 0; q < n; ++q) {
    Vec2 f = Vec2::Zero();
    if (restrict && !m_force_needed[static_cast<std::size_t>(q)]) {
      m_force[2 * q] = m_force[2 * q + 1] = 0.0;  // another rank's: its families are not computed here
      continue;
    }
    for (Index b = bonds.start[q]; b < bonds.start[q + 1]; ++b) {
      const Index j = bonds.neighbour[b], r = bonds.reverse[b];
      f += p.volume[j] * m_t[r] * m_direction[r] - p.volume[q] * m_t[b] * m_direction[b];
    }
    m_force[2 * q] = f.x();
    m_force[2 * q + 1] = f.y();
  }
}

void QuasiStaticProblem::expand_state(const VectorXd& x) {
  if (!m_options.import_ghosts) return expand(x, m_u);
  m_x_ghosts = x;  // the same size every time: the storage stays
  m_options.import_ghosts(m_x_ghosts);
  expand(m_x_ghosts, m_u);
}

double QuasiStaticProblem::norm(const VectorXd& v) const {
  if (!part()) return v.norm();
  return std::sqrt(m_options.sum_over_ranks(v.head(m_options.owned_unknowns).squaredNorm()));
}

bool QuasiStaticProblem::all_finite(const VectorXd& v) const {
  if (!part()) return v.allFinite();
  return m_options.max_over_ranks(v.head(m_options.owned_unknowns).allFinite() ? 0.0 : 1.0) == 0.0;
}

double QuasiStaticProblem::force_norm() const {
  // A part's forces are its own particles' (and those without an owner, alike on every rank).
  if (!m_own_rows_only && !part()) return m_force.norm();
  // Each rank's own particles, summed over the ranks, and the particles without a row (every
  // rank computes those alike), added once.
  const OwnedRows& rows = m_options.rows;
  double own = 0.0, unowned = 0.0;
  for (Index q = 0; q < m_model.particles.size(); ++q) {
    const int owner = rows.owner[static_cast<std::size_t>(q)];
    const double f2 = m_force[2 * q] * m_force[2 * q] + m_force[2 * q + 1] * m_force[2 * q + 1];
    if (owner == rows.rank)
      own += f2;
    else if (owner < 0)
      unowned += f2;
  }
  return std::sqrt(m_options.sum_over_ranks(own) + unowned);
}

bool QuasiStaticProblem::set_own_rows_only(bool on) {
  if (!distributed()) return false;
  if (on) build_own_masks();
  m_own_rows_only = on;
  return true;
}

std::vector<Index> QuasiStaticProblem::action_reads() const {
  // The particles whose displacement the own rows' action reads: each own particle, its
  // neighbours and theirs (the dilatation rates of its neighbours' families), and its contact
  // partners; a mirror ghost among them reads its source.
  const OwnedRows& rows = m_options.rows;
  const Bonds& bonds = m_model.bonds;
  const Constraints& cons = m_model.constraints;
  const Index n = m_model.particles.size();
  std::vector<char> read(static_cast<std::size_t>(n), 0), near(read);
  for (Index q = 0; q < n; ++q) {
    if (!rows.contains(q)) continue;
    near[static_cast<std::size_t>(q)] = 1;
    for (Index b = bonds.start[q]; b < bonds.start[q + 1]; ++b)
      near[static_cast<std::size_t>(bonds.neighbour[b])] = 1;
    if (m_contact)
      for (auto e = m_contact->incident_begin(q); e != m_contact->incident_end(q); ++e)
        read[static_cast<std::size_t>(e->other)] = 1;
  }
  for (Index i = 0; i < n; ++i) {
    if (!near[static_cast<std::size_t>(i)]) continue;
    read[static_cast<std::size_t>(i)] = 1;
    for (Index b = bonds.start[i]; b < bonds.start[i + 1]; ++b)
      read[static_cast<std::size_t>(bonds.neighbour[b])] = 1;
  }
  // (A plane mirror puts a read ghost's source within the same reach, by symmetry; the rule
  // holds for any image.)
  return read_unknowns(cons, read);
}

std::vector<Index> QuasiStaticProblem::residual_reads() const {
  const_cast<QuasiStaticProblem*>(this)->build_own_masks();
  const Bonds& bonds = m_model.bonds;
  const Constraints& cons = m_model.constraints;
  const Index n = m_model.particles.size();
  std::vector<char> read(static_cast<std::size_t>(n), 0);
  for (Index i = 0; i < n; ++i) {
    if (!m_family_needed[static_cast<std::size_t>(i)]) continue;
    read[static_cast<std::size_t>(i)] = 1;
    for (Index b = bonds.start[i]; b < bonds.start[i + 1]; ++b)
      read[static_cast<std::size_t>(bonds.neighbour[b])] = 1;
  }
  if (m_contact)
    for (const ContactPair& c : m_contact->pairs())
      read[static_cast<std::size_t>(c.i)] = read[static_cast<std::size_t>(c.j)] = 1;
  return read_unknowns(cons, read);
}

void QuasiStaticProblem::build_own_masks() {
  if (!m_force_needed.empty()) return;
  // The forces this rank computes: its particles' and those of the particles without a row
  // (fictitious layers, mirror ghosts: no unknown reads them, but the force scale counts their
  // reactions, force_norm()). Their forces read the families of their neighbours.
  const OwnedRows& rows = m_options.rows;
  const Bonds& bonds = m_model.bonds;
  const Index n = m_model.particles.size();
  m_force_needed.assign(static_cast<std::size_t>(n), 0);
  m_family_needed.assign(static_cast<std::size_t>(n), 0);
  for (Index q = 0; q < n; ++q) {
    const int owner = rows.owner[static_cast<std::size_t>(q)];
    if (owner != rows.rank && owner >= 0) continue;
    m_force_needed[static_cast<std::size_t>(q)] = 1;
    m_family_needed[static_cast<std::size_t>(q)] = 1;
    for (Index b = bonds.start[q]; b < bonds.start[q + 1]; ++b)
      m_family_needed[static_cast<std::size_t>(bonds.neighbour[b])] = 1;
  }
  const std::vector<Index>& free = m_model.constraints.free_index;
  for (std::size_t c = 0; c < free.size(); ++c)
    if (free[c] >= 0 && !rows.contains(static_cast<Index>(c / 2))) m_other_unknowns.push_back(free[c]);
}

void QuasiStaticProblem::gather_tangent(SparseMatrix& K) const {
  // Column particle p gathers the Hessian blocks (q, p) of every family energy V_i W_i with
  // p in {i} + family(i) (docs/theory/osb.md, "Assembly"):
  //   family of p:         (p,p) += V_p sum_b k_b + bV_p s_p s_p^T,
  //                        (j,p) += -V_p k_b + bV_p s_b s_p^T
  //   family of i ~ p (r = i -> p): (i,p) += -V_i k_r + bV_i s_i s_r^T,  (p,p) += V_i k_r,
  //                        (j,p) += bV_i s_c s_r^T for every bond c = i -> j.
  const Bonds& bonds = m_model.bonds;
  const Particles& part = m_model.particles;
  const Constraints& cons = m_model.constraints;
#pragma omp parallel
  {
    ColumnWriter col(m_model, m_pattern, K);
    // The blocks (q, p) of column particle p, written into the current column.
    const auto column = [&](Index p) {
      // Family of p.
      const double Vp = part.volume[p], bVp = m_beta_volume[p];
      const Vec2& sp = m_s_self[p];
      col.add_outer(p, bVp, sp, sp);
      for (Index b = bonds.start[p]; b < bonds.start[p + 1]; ++b) {
        col.add_sym(p, Vp, m_kbond[b]);
        const Index j = bonds.neighbour[b];
        col.add_sym(j, -Vp, m_kbond[b]);
        col.add_outer(j, bVp, m_s[b], sp);
      }
      // Families of the neighbours of p.
      for (Index b = bonds.start[p]; b < bonds.start[p + 1]; ++b) {
        const Index i = bonds.neighbour[b], r = bonds.reverse[b];
        // Partitioned bonds: no reverse when i's family is not held; then neither i nor any
        // particle of its family is this rank's row (check_partition()), so nothing is lost.
        if (r < 0) continue;
        const double Vi = part.volume[i], bVi = m_beta_volume[i];
        const Vec2& sr = m_s[r];
        col.add_sym(i, -Vi, m_kbond[r]);
        col.add_outer(i, bVi, m_s_self[i], sr);
        col.add_sym(p, Vi, m_kbond[r]);
        for (Index c = bonds.start[i]; c < bonds.start[i + 1]; ++c)
          col.add_outer(bonds.neighbour[c], bVi, m_s[c], sr);
      }
    };
#pragma omp for schedule(static)
    for (Index p = m_pattern.col_first; p < m_pattern.col_end; ++p) {
      if (!col.begin(p)) continue;
      column(p);
      // Mirror ghosts of p depend on u_p: their columns fold into p's (chain rule).
      if (cons.has_images())
        for (Index k = cons.image_start[p]; k < cons.image_start[p + 1]; ++k) {
          col.fold_image(cons.images[k].sign);
          column(cons.images[k].ghost);
          col.fold_image({1.0, 1.0});
        }
      // Contact pairs of p: d r_p / d u_p = J, d r_other / d u_p = -J.
      if (m_contact)
        for (auto e = m_contact->incident_begin(p); e != m_contact->incident_end(p); ++e)
          col.add_pair(e->other, m_contact->jacobian(e->pair));
      col.end();
    }
  }
}

SparseMatrix QuasiStaticProblem::make_preconditioner() {
  if (!m_preconditioner)
    m_preconditioner = std::make_unique<BondPreconditioner>(
        m_model, m_options.bond_preconditioner, m_contact.get(),
        m_correction.method() == SurfaceCorrectionMethod::none ? std::span<const double>(m_model.bonds.weight)
                                                               : m_correction.weights(),
        m_options.rows);
  return m_preconditioner->make_matrix();
}

void QuasiStaticProblem::assemble_preconditioner(SparseMatrix& P) {
  if (!m_preconditioner) make_preconditioner();
  m_preconditioner->assemble(P, m_correction.weights(), m_direction);
  decouple_fragments(P);
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
  m_bonds_changed = true;
  update_fragments();
  return count;
}

void QuasiStaticProblem::check_mirror_zone(const std::vector<std::pair<Index, Index>>& broken) {
  if (m_mirror_zone.empty() && !part()) return;  // a part without mirror images still takes part
  std::vector<double> found;                     // the bond's ends
  for (const auto& [i, j] : broken) {
    if (m_mirror_zone.empty()) break;
    if (!m_mirror_zone[i] && !m_mirror_zone[j]) continue;
    const Vec2 &a = m_model.particles.position[i], &b = m_model.particles.position[j];
    found = {a.x(), a.y(), b.x(), b.y()};
    break;
  }
  // On a part, each rank sees the pairs it holds: the first rank's bond that found one.
  if (part()) {
    const std::vector<double> all = m_options.gather_over_ranks(found);
    found.assign(all.begin(),
                 all.begin() + std::min<std::ptrdiff_t>(4, static_cast<std::ptrdiff_t>(all.size())));
  }
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
  m_bonds_changed = false;
  collect_changed_families(m_failure->last_round());
  m_failure->revert();
  if (!m_changed_families.empty()) m_correction.update(m_failure->weights(), m_changed_families);
  if (m_contact) {
    m_contact->drop_last_round();
    m_contact->start_trial(1.0);  // the failed re-solve's multipliers go too
  }
  update_fragments();
}

void QuasiStaticProblem::collect_changed_families(const std::vector<std::pair<Index, Index>>& pairs) {
  m_changed_families.clear();
  for (const auto& [i, j] : pairs) {
    m_changed_families.push_back(i);
    m_changed_families.push_back(j);
  }
  std::sort(m_changed_families.begin(), m_changed_families.end());
  m_changed_families.erase(std::unique(m_changed_families.begin(), m_changed_families.end()),
                           m_changed_families.end());
}

std::size_t QuasiStaticProblem::memory_bytes() const {
  auto bytes = [](const auto& v) { return v.capacity() * sizeof(v[0]); };
  std::size_t total =
      m_correction.memory_bytes() + bytes(m_changed_families) + bytes(m_eta) + bytes(m_eta_scratch) +
      bytes(m_direction) + bytes(m_s) + bytes(m_t) + bytes(m_kbond) + bytes(m_s_self) + bytes(m_beta_volume) +
      static_cast<std::size_t>(m_u.size() + m_force.size() + m_velocity.size()) * sizeof(double) +
      m_pattern.memory_bytes();
  if (m_failure) total += m_failure->memory_bytes();
  if (m_preconditioner) total += m_preconditioner->memory_bytes();
  if (m_contact) total += m_contact->memory_bytes();
  return total;
}

}  // namespace peristat
