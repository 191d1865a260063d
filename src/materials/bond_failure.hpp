// The failure state of the bonds (docs/theory/failure.md): critical values per body, the
// skew's reference bond per particle, and the intact bond weights the OSB kernel reads. A
// round of breaking is a trial until commit(); revert() restores its bonds (a round whose
// re-solve did not converge). Broken bonds never heal once a state with them converged.
//
// A rank of a distributed run whose model holds some families only (partitioned bonds,
// Model::family_held) takes the same decisions as one process holding every family, bit for
// bit: each pair is evaluated by one rank (FailureRanks::proposes), the candidates over the
// criterion are gathered on every rank and sorted as one process sorts them, and every rank
// zeroes the directions it holds (docs/guide/distributed.md, "Failure on the parts").
#pragma once

#include <cstdint>
#include <span>
#include <utility>
#include <vector>

#include "core/global_ids.hpp"
#include "core/options.hpp"
#include "core/state_archive.hpp"
#include "discretisation/model.hpp"
#include "parallel/exchange.hpp"
#include "parallel/ranks.hpp"

namespace peristat {

/// A rank's share of the failure decisions when its model holds some families only.
struct FailureRanks {
  /// Per particle: this rank evaluates the pairs (i, j > i) of particle i's family, which it
  /// holds with the families of i's neighbours. Every pair is proposed by exactly one rank
  /// (a rank's own particles; rank 0's also those without a row).
  std::vector<char> proposes;
  /// Per particle values (N): copies the owners' entries into the ranks that hold them; the
  /// entries of particles without a row stay as each rank computed them. Owned by the caller.
  ValueExchange* share = nullptr;
  /// On a rank's part of the model (discretisation/model_part.hpp): its particles' numbers in
  /// the whole model (owned by the caller). Null: the model's particles are the whole model's.
  const GlobalIds* ids = nullptr;
};

class BondFailure {
 public:
  /// options.enabled must be true. `share` is required when the model holds some families
  /// only, and ignored otherwise; then break_over_criterion(), damage(), save() and
  /// restore() are collective over `ranks` (every rank calls them at the same point).
  BondFailure(const Model& model, const FailureOptions& options, const Ranks& ranks = serial_ranks(),
              FailureRanks share = {});

  /// Evaluates the criterion of every bond from the relative displacements eta (per bond,
  /// eta_b = u_j - u_i) and breaks the intact pairs over it: a pair breaks when
  /// max(value / critical) over its two directions exceeds 1; the most critical
  /// `fraction` of those (at least one), at most `at_most` when at_most > 0. Pairs between
  /// two fictitious particles never break. Returns the pairs broken (i, j), each once; on a
  /// part (FailureRanks::ids) those of which it holds a direction, by the part's indices
  /// (broken() counts every rank's).
  const std::vector<std::pair<Index, Index>>& break_over_criterion(std::span<const Vec2> eta, Index at_most);
  /// Particles whose bonds the criterion leaves alone (N, 1: held; empty: none): the held
  /// fragments (docs/theory/failure.md, "Fragments"), whose bonds stretch as wherever they
  /// were cut loose, a position the equations do not determine. Their pairs neither break
  /// nor count for peak().
  void set_held(const std::vector<char>& held) { m_held_particle = held; }
  /// The pairs of the last round (broken, or restored by revert()).
  const std::vector<std::pair<Index, Index>>& last_round() const { return m_round; }
  /// How many pairs the last round broke, every rank's (on a part, last_round() holds those of
  /// which this rank holds a direction).
  Index round_pairs() const { return m_round_pairs; }
  /// The last round is kept for good.
  void commit();
  /// Restores the bonds of the last round (only the last round can be undone).
  void revert();

  /// Bond quadrature weights with the broken bonds at 0 (the kernel's input).
  std::span<const double> weights() const { return m_weight; }
  /// Bonds broken since the start (pairs).
  Index broken() const { return m_broken; }
  /// The intact pair (i, j), i < j, closest to breaking at the last evaluation: its larger
  /// ratio value / critical of the two directions (0 and particles -1 before the first
  /// evaluation or when no pair can break). After a round that broke nothing, this is how far
  /// the converged state is from the criterion.
  /// The particles by their whole model's index (global id on a part), and the pair's
  /// midpoint in the reference configuration.
  struct Peak {
    double ratio = 0.0;
    Index i = -1, j = -1;
    Vec2 at = Vec2::Zero();
  };
  Peak peak() const { return m_peak; }
  /// skew: the reference bond of particle i (global bond index; -1 without an intact bond
  /// or for critical stretch).
  Index reference(Index i) const { return m_reference_bond.empty() ? -1 : m_reference_bond[i]; }
  /// Damage of each particle, 1 - sum of intact bond weights / sum of all (N).
  void damage(VectorXd& d) const;
  /// Particle i's index in the whole model, and the part's particle of a whole index (-1: not
  /// in the part). The identity on a whole model.
  std::int64_t global(Index i) const { return ids()[i]; }
  Index local(std::int64_t g) const { return ids().local_of(g); }
  const GlobalIds& ids() const { return m_share.ids ? *m_share.ids : m_own; }
  const FailureRanks& share() const { return m_share; }
  std::size_t memory_bytes() const;
  /// The committed state (broken pairs, skew references) into / from a checkpoint
  /// (peristat run --resume), with the whole model's bond indices whatever the ranks hold.
  /// restore() expects a fresh object of the same model, and returns the pairs it broke.
  void save(StateArchive& archive) const;
  std::vector<std::pair<Index, Index>> restore(const StateArchive& archive);

 private:
  /// A pair to break: (i, k) and (j, kr) its two directions, bond k of i's family and kr of
  /// j's, i < j by their whole model's indices; ratio its criterion, whole the whole model's
  /// index of bond (i, k).
  struct Candidate {
    double ratio;
    std::int64_t i;
    Index k;
    std::int64_t j;
    Index kr;
    std::int64_t whole;
  };
  /// A rank's peak as the ranks gather it: by global ids, k the bond of i's family.
  struct RankPeak {
    double ratio;
    std::int64_t i, k, j;
    double x, y;
  };
  /// Breaks the pair on every rank: the directions this rank holds; records it.
  void break_candidate(const Candidate& x);
  /// How many of `over` pairs over the criterion a round breaks (fraction, at_most).
  std::size_t pairs_to_break(std::size_t over, Index at_most) const;
  /// Zeroes the directions this process holds and records the pair in the round.
  void break_pair(Index i, Index bi, Index j, Index bj);
  void reselect_references();
  /// Numbers the particles: a part's global ids, or the identity (one process); every
  /// family's whole index, and which families are held.
  void number_particles(Index n);
  /// The largest ratio of the pairs this rank proposes, then every rank's candidates into
  /// m_candidates (in rank order) and the peak over the ranks into m_peak.
  void gather_candidates();
  /// Restore: each pair of the checkpoint resolved by the rank proposing its first particle's
  /// family, then every pair in the checkpoint's order.
  std::vector<Candidate> restored_pairs(const std::vector<double>& broken) const;

  const Model& m_model;
  FailureOptions m_options;
  const Ranks& m_ranks;
  FailureRanks m_share;
  std::vector<double> m_critical;                ///< per body: s_c or gamma_c
  double m_min_sin;                              ///< skew: sin(skew_min_angle), the floor of |xi . e2| / |xi|
  std::vector<Index> m_reference_bond;           ///< skew: per particle, the reference bond (global index), intact
  std::vector<std::pair<Index, Index>> m_round_references;  ///< (particle, reference before the last round)
  std::vector<double> m_weight;                  ///< per bond, 0 once broken
  std::vector<double> m_ratio;                   ///< per bond: criterion value / critical (scratch)
  std::vector<std::pair<Index, Index>> m_round;  ///< pairs broken by the last round
  std::vector<std::pair<Index, Index>> m_round_bonds;  ///< their directions held here: (particle, bond)
  std::vector<Candidate> m_candidates;                 ///< scratch: every rank's candidates
  std::vector<std::int64_t> m_broken_whole;            ///< every broken pair's whole index
  GlobalIds m_own;  ///< a whole model's identity numbering (no FailureRanks::ids)
  std::vector<char> m_held;                   ///< per particle: its family is held here
  std::vector<char> m_held_particle;          ///< per particle: held as a fragment (set_held)
  std::vector<std::int64_t> m_whole_start;    ///< per particle (N + 1): its family's first whole bond index
  Index m_round_pairs = 0;                                  ///< pairs broken by the last round, every rank's
  Index m_broken = 0;
  Peak m_peak;
};

}  // namespace peristat
