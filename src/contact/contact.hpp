// Contact between particles that hold no bond: the faces of pre-cracks and declared body
// interfaces (paper section 3, eqs 12-17; docs/theory/contact.md). ContactSystem is the facade
// the assembler uses: it evaluates every candidate pair with the pair law
// (contact/pair_law.hpp), keeps the results of the last evaluation, the counts, signature and
// checks, and holds the rooms it draws on: the candidate search (contact/candidate_search.hpp),
// the pairs' state (slip, multipliers, boosts: contact/contact_state.hpp) and the part's
// numbering (contact/contact_ids.hpp). Derivations: docs/theory/contact.md.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "contact/candidate_search.hpp"
#include "contact/contact_ids.hpp"
#include "contact/contact_state.hpp"
#include "contact/pair_law.hpp"
#include "core/options.hpp"
#include "core/state_archive.hpp"
#include "core/types.hpp"
#include "discretisation/model.hpp"

namespace peristat {

/// Outcome of ContactSystem::update_multipliers().
struct MultiplierUpdate {
  enum class Status { satisfied, updated, exhausted };
  Status status = Status::satisfied;
  /// Largest constraint violation over the facing pairs: the closure s of any pair, the
  /// opening -s of a pair that still carries a force (s = (a - n.Y) / a, plus the material's
  /// strain where that is the reference; both times the window phi), or (exact stick) the
  /// slip |w - w_p| / a of a stuck pair from its anchor.
  double violation = 0.0;
  /// Largest opening -(a - n.Y) / a of a facing pair that carries a force (a force across a
  /// gap: the multipliers' complementarity error).
  double opening = 0.0;
  /// The pair with that violation, by its ends' global ids (the particle indices in one
  /// process; -1: none).
  std::int64_t pair_i = -1, pair_j = -1;
  /// What that pair violates: "closure" (it overlaps), "opening under load" (a force across a
  /// gap) or "stuck slip" (exact stick: its slip from the anchor).
  const char* kind = "closure";
  int updates = 0;  ///< updates made in this increment so far
};

/// Counts of the last evaluation.
struct ContactCounts {
  Index candidates = 0, open = 0, stick = 0, slip = 0;
  Index active() const { return stick + slip; }
};

/// A pair that has crossed: its ends by global id (the particle index in one process) and
/// reference positions, and n.Y [m].
struct CrossedPair {
  std::int64_t i = -1, j = -1;
  Vec2 Xi = Vec2::Zero(), Xj = Vec2::Zero();
  double normal = 0.0;
  bool any() const { return i >= 0; }
};

class ContactSystem {
 public:
  /// Builds the candidate pairs the options ask for (the faces of the model's pre-cracks if
  /// options.cracks, declared interfaces between the model's bodies). Throws InputError when
  /// a declared interface has no common boundary. With `share` (a rank's part of the model)
  /// the part's share, and the constructor is collective over `ranks`.
  ContactSystem(const Model& model, const ContactOptions& options, const Ranks& ranks = serial_ranks(),
                ContactRanks share = {});
  /// Its rooms refer to its members: neither copied nor moved.
  ContactSystem(const ContactSystem&) = delete;
  ContactSystem& operator=(const ContactSystem&) = delete;

  const std::vector<ContactPair>& pairs() const { return m_state.pairs(); }
  const ContactLaw& law() const { return m_law; }
  Index size() const { return m_state.size(); }

  /// Evaluates every pair at the full displacement u (2N, interleaved).
  void evaluate(const VectorXd& u, bool want_jacobian);
  /// While on, evaluate() with a Jacobian closes each open pair that touches (the edge of
  /// its gate: distance within delta_c, not separated along the normal; under exact
  /// enforcement, facing within the window): status stick (slip without friction), force
  /// zero, and the Jacobian of a closed pair at full gate, (C/a) n n^T (+ k_t t t^T with
  /// friction). The Euler predictor's tangent (EvaluationMode::touching_closed).
  void set_touching_closed(bool on) { m_touching_closed = on; }
  /// Adds the contact part of dPi/du (2N) of the last evaluation.
  void add_internal_force(VectorXd& force) const;
  /// The contact force acting on each particle (2N) [N] of the last evaluation.
  void contact_force(VectorXd& out) const;
  /// Per particle (N), the state of its pairs at the last evaluation: 0 when no pair of the
  /// particle is closed, 1 when its closed pairs all stick, 2 when one of them slips.
  void particle_states(std::vector<int>& out) const;
  /// Accepts u as converged: slip history is updated, pairs added since the last commit stay.
  void commit(const VectorXd& u);
  /// Bonds broken during the run become candidates (paper section 4.4): pair (i, j) with
  /// normal along the bond, gap0 = |X_j - X_i|, no stored tangential force. Pairs with a
  /// fictitious end are skipped, and on a part those that touch none of its own particles.
  /// `u` is the current displacement (2N). The pairs are a trial
  /// round until commit(); drop_last_round() removes them.
  void add_broken_bonds(const std::vector<std::pair<Index, Index>>& bonds, const VectorXd& u);
  /// Removes the pairs of the last add_broken_bonds() (a round whose re-solve failed); does
  /// nothing when no pair was added since the last commit.
  void drop_last_round();
  /// Exact enforcement: starts a trial of the load increment from the committed multipliers
  /// scaled by `ratio` (the new load factor over the committed one: proportional loading
  /// predicts proportional contact forces) and resets the update count. No-op for penalty.
  void start_trial(double ratio);
  /// Exact enforcement, at the converged state u of the current multipliers: satisfied when
  /// every facing pair's violation is within contact.closure_tolerance (its closure s, or
  /// |s| while it carries a force: no penetration, and no force across a gap; with friction,
  /// the slip of a stuck pair from its anchor); otherwise each facing pair's multiplier
  /// becomes max(0, lambda + C s) (Uzawa), its tangential one its friction force, and the caller solves
  /// again, up to contact.max_multiplier_updates times (then `exhausted`). Penalty: satisfied.
  /// `bond_weights` (one per bond, 0 for a broken one; empty: the model's, no bond broken) serve the material
  /// closure reference: each facing pair's strain is set first, from the families of its two particles at u.
  MultiplierUpdate update_multipliers(const VectorXd& u, std::span<const double> bond_weights);
  /// The first candidate that has crossed at u (n.Y < 0 while facing, `crossed()`), or -1.
  Index first_crossed(const VectorXd& u) const;
  /// The first crossed pair in the whole model's order (on a part: over every rank's own
  /// pairs, collective), or none.
  CrossedPair first_crossed_pair(const VectorXd& u) const;
  /// On a part: the particles of a face within `reach` of one of this rank's own particles of
  /// the other face at u that this part does not hold (CandidateSearch::partners_not_held(),
  /// collective). With reach = search_radius(), a partner search on the part would miss their
  /// pairs: the parts must grow before the run goes on. Empty on a whole model.
  std::vector<std::int64_t> partners_not_held(const VectorXd& u, double reach) const {
    return m_search.partners_not_held(u, reach);
  }
  /// The radius of a partner search [m].
  double search_radius() const { return m_search.search_radius(); }
  /// This model holds every particle of the whole (a whole model, or a part that took in all):
  /// no partner of a face can lie outside it.
  bool holds_every_particle() const { return m_ids.holds_every_particle(); }
  /// Largest normal closure a - n.Y [m] over the pairs that carried a force in the last
  /// evaluation (0 when none did).
  double max_closure() const { return m_max_closure; }
  /// Exact enforcement: true when contact.stiffness exceeded the augmentation cap (10 x the
  /// eq 17 modulus) and the cap was used instead.
  bool augmentation_capped() const { return m_state.augmentation_capped(); }
  /// The multiplier of pair k [N] (exact enforcement; 0 under penalty).
  double multiplier(Index k) const { return m_state.multiplier(k); }
  const PairResult& result(Index k) const { return m_result[k]; }
  /// Velocity-sign law only: the full pseudo-velocity (2N) that the next evaluations use.
  void set_velocity(const VectorXd& v);
  bool wants_velocity() const { return m_law.velocity_sign; }
  /// Coulomb friction with a slip history (friction > 0, not the velocity-sign law): every
  /// pair, those added later included, has an entry in the slip state, even when the run
  /// starts with no candidate (a scene whose contact pairs are all broken bonds).
  bool tracks_slip() const { return m_law.tracks_slip(); }

  /// Pairs touching particle p: (pair index, +1 if p is j, -1 if p is i), from the CSR
  /// `pairs_of(p)`: entries m_incident[m_incident_start[p] .. m_incident_start[p+1]).
  struct Incidence {
    Index pair;
    Index other;
    int sign;  ///< +1: p is j; -1: p is i
  };
  const Incidence* incident_begin(Index p) const { return m_incident.data() + m_incident_start[p]; }
  const Incidence* incident_end(Index p) const { return m_incident.data() + m_incident_start[p + 1]; }
  const Mat2& jacobian(Index pair) const { return m_result[pair].J; }
  /// A positive semi-definite stand-in for the Jacobian in a preconditioner matrix:
  /// (C/a) n n^T for a pair in contact, plus k_t t t^T when it sticks.
  Mat2 preconditioner_block(Index pair) const;
  /// An upper bound of |J| entries of the pair in any state it can reach (ADR's
  /// fictitious density must cover pairs that switch on during a step): C (1/a + 1/delta_c
  /// + k_t a / C if friction) plus C / (gate delta_c) on the paper law's ramp (s <= 1).
  double stiffness_bound(Index pair) const;

  /// True when every pair's Jacobian in the last evaluation that computed them is symmetric: no pair slips
  /// with friction and none is on the switch-on ramp of the paper law.
  bool symmetric() const { return m_symmetric; }
  const ContactCounts& counts() const { return m_counts; }
  /// A hash of every pair's status in the last evaluation (detects active-set cycling).
  std::uint64_t signature() const { return m_signature; }
  /// Smallest current distance |Y| over the candidate pairs at the last evaluation [m].
  double min_distance() const { return m_min_distance; }
  /// Bytes held by the pairs, their history and results, and the incidence lists.
  std::size_t memory_bytes() const;

  /// Large sliding (docs/theory/contact.md, section 10). The largest relative tangential
  /// motion t.(du_j - du_i) of a pair since the last partner search [m] (on a part: over
  /// every rank's pairs, collective).
  double slide_since_search(const VectorXd& u) const;
  /// Searches the faces of the pre-cracks and interfaces for partners in the current
  /// configuration u: every pair of particles of the two sides within one horizon plus one
  /// spacing of each other becomes a candidate (crack faces: unless bonded). Known pairs
  /// keep their history; new ones start open. Returns true when pairs were added (the
  /// tangent's pattern must then grow: version() changes). commit() calls it once the
  /// faces have slid half a spacing since the last search.
  bool search(const VectorXd& u);

  /// Particles held in place and taken out of the system (fragments, per particle 1). A pair
  /// of two held particles stays open and is not checked for crossing; a pair with one held
  /// particle acts on the other as a fixed obstacle would (the caller zeroes the held rows).
  void set_excluded(const std::vector<char>& excluded) { m_excluded = excluded; }

  /// The committed state (every candidate pair, its friction slip, multiplier and boost, the
  /// displacement of the last partner search) into / from a checkpoint (peristat run
  /// --resume). restore() replaces the candidates; version() changes.
  void save(StateArchive& archive) const;
  void restore(const StateArchive& archive);
  /// Changes whenever the candidate set grows by a search.
  std::uint64_t version() const { return m_version; }
  /// Searches done so far.
  int searches() const { return m_search.searches(); }
  /// The slide after which a search misses a partner that could already face a particle:
  /// the search radius less the window's reach (sqrt 2 dx) and the trigger (section 10).
  double max_slide_between_searches() const { return m_search.max_slide_between_searches(); }

 private:
  /// The largest violation over every rank's own pairs (the first in the whole model's order
  /// of equals) and the largest opening, from this rank's `mine` (collective).
  MultiplierUpdate worst_over_ranks(const MultiplierUpdate& mine) const;
  /// Material closure reference: the compressive normal strain min(0, n.E.n) at pair c, E the
  /// mean of its two particles' family strains at u (family_strain()).
  double pair_strain(const ContactPair& c, const VectorXd& u, std::span<const double> bond_weights);
  /// The constructor's steps: the pair law from the options; the candidates found in the
  /// reference configuration with their starting state; their count over the ranks.
  static ContactLaw law_of(const ContactOptions& options, double spacing);
  void start_candidates(const ContactOptions& options);
  void count_candidates();
  /// Appends pair c in the state of an open pair at u.
  void add_pair(const ContactPair& c, const VectorXd& u);
  void build_incidence();
  /// On a part: the counts, signature, symmetry and distances of the last evaluation over
  /// every rank's own pairs (collective).
  void reduce_over_ranks(bool want_jacobian);
  /// The particle's global id, and whether this rank counts it (ContactIds).
  std::int64_t gid(Index i) const { return m_ids.gid(i); }
  bool counted(Index i) const { return m_ids.counted(i); }
  /// A pair of two held particles (set_excluded).
  bool excluded(const ContactPair& c) const { return !m_excluded.empty() && m_excluded[c.i] && m_excluded[c.j]; }

  const Model& m_model;
  ContactIds m_ids;
  ContactLaw m_law;
  PairStiffness m_stiffness;
  CandidateSearch m_search;
  ContactState m_state;  ///< the pairs, their slip, multipliers and boosts
  double m_closure_tolerance = 0.0;
  int m_max_multiplier_updates = 0;
  std::vector<PairResult> m_result;
  std::vector<Index> m_incident_start;
  std::vector<Incidence> m_incident;
  ContactCounts m_counts;
  std::uint64_t m_signature = 0;
  bool m_symmetric = true;
  bool m_touching_closed = false;  ///< set_touching_closed()
  double m_min_distance = 0.0;
  double m_max_closure = 0.0;
  std::uint64_t m_version = 0;
  std::vector<char> m_excluded;  ///< per particle, or empty: none excluded
  /// Material closure reference, per particle: its family strain (exx, eyy, exy) and whether
  /// it was computed at the current update.
  std::vector<Eigen::Vector3d> m_family_strain;
  std::vector<char> m_family_strain_done;
};

}  // namespace peristat
