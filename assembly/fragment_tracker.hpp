// Fragments (docs/theory/failure.md, "Fragments"): particles whose piece of the body lost
// every bond to the prescribed displacements by breaking (a piece the scene declared without
// support is not one). They are held where they were and taken out of the system: zero
// residual, a diagonal tangent; to the rest of the model a held particle is a fixed obstacle,
// its contact pairs with free particles stay active.
#pragma once

#include <cstddef>
#include <memory>
#include <vector>

#include "contact/contact.hpp"
#include "core/types.hpp"
#include "discretisation/model.hpp"
#include "materials/bond_failure.hpp"
#include "materials/fragments.hpp"

namespace peristat {

struct ProblemOptions;

/// The fragments at the failure state's current bonds. A function of the bonds alone: update()
/// after every change of them (a round of breaking, its undoing, a restore).
class FragmentTracker {
 public:
  /// Without failure (null) there are never fragments. `options` (the problem's, which must
  /// outlive this) gives the rows and the collectives of a distributed run.
  /// `particle_values`: with partitioned bonds, the exchange of one value per particle
  /// (RankExchanges::particle_values(), the problem's).
  FragmentTracker(const Model& model, BondFailure* failure, const ProblemOptions& options, const Ranks& ranks,
                  ValueExchange* particle_values);
  FragmentTracker(const FragmentTracker&) = delete;
  FragmentTracker& operator=(const FragmentTracker&) = delete;

  /// The fragments at the current bonds; the contact pairs (when modelled) exclude them, and
  /// the failure criterion leaves their bonds alone (BondFailure::set_held). On a part: collective.
  void update(ContactSystem* contact);
  /// update() after a round of breaking that cut the pairs `broken`, unless the round cannot
  /// have changed the bond graph's components: in one process, when each pair's two particles
  /// still share a neighbour through intact bonds (any path through a cut pair then goes round
  /// it), the fragments are those of before and the search over every bond is spared.
  void update_after_round(ContactSystem* contact, const std::vector<std::pair<Index, Index>>& broken);
  /// Searches of the whole bond graph so far (update() calls that did not skip).
  long graph_searches() const { return m_graph_searches; }
  /// Takes the fragments' components out of the forces of an evaluation (zero), and records
  /// the net force they take from the rest of the model (reaction()). On a part with
  /// fragments: collective.
  void hold(VectorXd& force);
  /// Fragment unknowns of K: rows and columns zero, the diagonal the largest of K's.
  void decouple(SparseMatrix& K) const;

  /// Fragment particles (on a part, every rank's) and fragments.
  Index particles() const { return m_fragment_particles; }
  Index count() const { return m_fragments; }
  /// Contact pairs between a held fragment particle and a free one that carry a force at the
  /// last evaluation of `contact`, and the magnitude of the net force they put on the held
  /// fragments at the last hold() [N]: the reaction of the support that holds them, which
  /// nothing in the model balances.
  Index contacts(const ContactSystem* contact) const;
  double reaction() const { return m_fragment_reaction; }
  /// Per particle of the model (of the part): 1 where it belongs to a fragment.
  const std::vector<char>& particles_held() const { return m_fragment; }
  /// The fragments' unknowns.
  const std::vector<Index>& unknowns() const { return m_fragment_unknowns; }
  std::size_t memory_bytes() const;

 private:
  const Model& m_model;
  BondFailure* m_failure;
  const ProblemOptions& m_options;
  const Ranks& m_ranks;
  /// With partitioned bonds and failure: this rank's part of the bond graph (null otherwise).
  std::unique_ptr<GraphParts> m_graph_parts;
  // Per particle: pieces without support before any bond broke, the fragments now, scratch;
  // the fragments' unknowns and components.
  std::vector<char> m_initially_unsupported, m_fragment, m_unsupported;
  std::vector<Index> m_component, m_fragment_unknowns, m_fragment_components;
  std::vector<char> m_fragment_unknown;  ///< per unknown: 1 for a fragment's
  Index m_fragment_particles = 0, m_fragments = 0;
  double m_fragment_reaction = 0.0;
  long m_graph_searches = 0;
  /// i and j share a neighbour k with the bonds i-k and k-j intact.
  bool joined_round(Index i, Index j) const;
};

}  // namespace peristat
