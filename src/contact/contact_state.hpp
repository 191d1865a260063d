// What the contact pairs remember between evaluations (docs/theory/contact.md): the candidate
// pairs themselves, the committed friction slip (eq 14), the pseudo-velocity of the
// velocity-sign law, and under exact enforcement the trial and committed multipliers and the
// augmentation boosts (section 8). Trial values during iterations, committed when a step
// converges; a round of pairs added from broken bonds is dropped when its re-solve fails. One
// checkpoint path by global id: a whole model is the case of identity ids.
#pragma once

#include <cmath>
#include <cstdint>
#include <vector>

#include "contact/contact_ids.hpp"
#include "contact/pair_law.hpp"
#include "core/state_archive.hpp"
#include "core/types.hpp"

namespace peristat {

class ContactState {
 public:
  /// `law` decides which histories are kept; `stiffness` sets the boosts of exact enforcement.
  /// Both must outlive the state.
  ContactState(const ContactLaw& law, const PairStiffness& stiffness);

  const std::vector<ContactPair>& pairs() const { return m_pairs; }
  Index size() const { return static_cast<Index>(m_pairs.size()); }
  /// The history pair k's kernel reads.
  PairHistory history(Index k) const {
    const bool stick = m_law.exact_stick();
    return {m_law.tracks_slip() ? m_slip[k] : 0.0,
            m_law.exact ? m_multiplier[k] : 0.0,
            m_law.velocity_sign ? m_tangential_velocity[k] : 0.0,
            m_law.exact ? m_boost[k] : 1.0,
            stick ? m_stick[k].force : 0.0,
            stick ? m_stick[k].limit_sign : 0.0,
            m_law.material_closure() ? m_strain[k] : 0.0};
  }
  /// The augmentation stiffness / C of pair k (1 under penalty).
  double boost(Index k) const { return m_law.exact ? m_boost[k] : 1.0; }
  /// The trial multiplier of pair k [N] (0 under penalty).
  double multiplier(Index k) const { return m_multiplier.empty() ? 0.0 : m_multiplier[k]; }

  /// The candidates found in the reference configuration: open, no slip, no multiplier.
  void start(std::vector<ContactPair> pairs);
  /// Appends a new pair c as an open pair at u starts: no stored tangential force (its slip is
  /// the current tangential offset), no multiplier.
  void append(const ContactPair& c, const VectorXd& u);
  /// Puts the pairs from `first` on in the order of their ends' global ids (on a part: the
  /// whole model's order).
  void sort_from(Index first, const ContactIds& ids);
  /// The pairs appended from now on form a trial round (add_broken_bonds).
  void start_round() { m_round_start = size(); }
  /// Removes the pairs of the last round; false when the round added none.
  bool drop_last_round();
  /// Exact enforcement: true when contact.stiffness exceeded the augmentation cap (10 x the
  /// eq 17 modulus) and the cap was used instead.
  bool augmentation_capped() const { return m_augmentation_capped; }
  /// On a part: the flag as reduced over the ranks (collective).
  void reduce_augmentation_capped(const ContactIds& ids);

  /// Velocity-sign law only: the relative tangential pseudo-velocity of every pair from the
  /// full pseudo-velocity v (2N).
  void set_velocity(const VectorXd& v);
  /// Exact enforcement: the trial multipliers from the committed ones scaled by `ratio`
  /// (under exact stick the tangential ones too; a pair at the limit stays there); the update
  /// count restarts. No-op for penalty.
  void start_trial(double ratio);
  /// Material closure reference: pair k's trial normal strain (PairHistory::strain).
  void set_strain(Index k, double strain) { m_strain[k] = strain; }
  /// Multiplier updates made in the current trial.
  int updates() const { return m_multiplier_updates; }
  /// Exact enforcement, one Uzawa update of every pair (per pair: facing, closure s,
  /// violation and the kernel's result at the converged state); returns the updates made in this trial. Under exact stick a stuck
  /// pair's multiplier takes its force, a sliding pair goes to the limit (+-f_c F at the
  /// current F), an open pair's goes to zero; anchors move only at commit.
  int update_multipliers(const std::vector<char>& facing, const std::vector<double>& closure,
                         const std::vector<double>& violation, const std::vector<PairResult>& result,
                         double closure_tolerance);
  /// Exact stick: the slip of a stuck pair from its anchor, |w - w_p| / a, at the tangential
  /// offset w (0 for the other laws).
  double stick_violation(Index k, double offset) const {
    return m_law.exact_stick() ? std::abs(offset - m_slip[k]) / m_pairs[k].gap0 : 0.0;
  }
  /// Accepts the trial: the round's pairs stay, the multipliers are committed.
  void commit_trial();
  /// Return-map friction: the slip of every pair at the converged u from its evaluation there.
  void update_slip(const VectorXd& u, const std::vector<PairResult>& result);

  /// The committed state (every candidate pair, its friction slip, multiplier and boost)
  /// into a checkpoint, in the whole model's order by global id (collective on a part).
  void save(StateArchive& archive, const ContactIds& ids) const;
  /// Replaces the pairs with the checkpoint's (on a part: those that touch its own
  /// particles); returns the number of pairs in the checkpoint.
  Index restore(const StateArchive& archive, const ContactIds& ids);
  /// Bytes held by the pairs and their history.
  std::size_t memory_bytes() const;

 private:
  /// Exact enforcement: the largest boost of a pair, kMaxAugmentationModulus x its eq 17 C / C.
  double boost_limit(const ContactPair& c) const;
  /// Exact enforcement: the boost a new pair starts with (the cap by default).
  double initial_boost(const ContactPair& c);
  /// Exact stick: pair k's tangential multiplier and limit sign from its state r.
  void set_tangential(Index k, const PairResult& r);

  const ContactLaw& m_law;
  const PairStiffness& m_stiffness;
  std::vector<ContactPair> m_pairs;
  Index m_round_start = 0;                    ///< first pair of the last add_broken_bonds() round
  std::vector<double> m_slip;                 ///< committed w_p per pair (empty without friction)
  /// Exact stick: a pair's tangential multiplier mu [N] and PairHistory::limit_sign.
  struct StickMultiplier {
    double force = 0.0, limit_sign = 0.0;
  };
  std::vector<StickMultiplier> m_stick;            ///< per pair, trial (exact stick only)
  std::vector<StickMultiplier> m_stick_committed;  ///< per pair, of the last converged state
  std::vector<double> m_tangential_velocity;  ///< per pair, velocity-sign law only
  std::vector<double> m_multiplier;            ///< per pair, trial lambda (exact enforcement only)
  std::vector<double> m_multiplier_committed;  ///< per pair, lambda of the last converged state
  std::vector<double> m_boost;                 ///< per pair, augmentation stiffness / C (exact)
  std::vector<double> m_last_violation;        ///< per pair, violation at the previous update (exact)
  std::vector<double> m_boost_limit;           ///< per pair, largest boost (exact)
  std::vector<double> m_strain;                ///< per pair, trial PairHistory::strain (material closure)
  std::vector<double> m_strain_committed;      ///< per pair, of the last converged state (material closure)
  int m_multiplier_updates = 0;                ///< in the current trial
  bool m_augmentation_capped = false;
};

}  // namespace peristat
