#include "assembly/fragment_tracker.hpp"

#include <algorithm>
#include <cmath>
#include <span>

#include "assembly/quasi_static.hpp"

namespace peristat {

FragmentTracker::FragmentTracker(const Model& model, BondFailure* failure, const ProblemOptions& options,
                                 const Ranks& ranks, ValueExchange* particle_values)
    : m_model(model), m_failure(failure), m_options(options), m_ranks(ranks) {
  if (!m_failure) return;
  if (!model.holds_every_family())  // a rank's part: its pieces joined with the other ranks'
    m_graph_parts = std::make_unique<GraphParts>(GraphParts{ranks, m_failure->share().proposes,
                                                            m_failure->ids().ids(),
                                                            std::span<const int>(m_options.rows.owner), particle_values});
  find_unsupported(model, m_failure->weights(), m_initially_unsupported, m_component, m_graph_parts.get());
  m_fragment.assign(model.particles.size(), 0);
}

void FragmentTracker::update_after_round(ContactSystem* contact,
                                         const std::vector<std::pair<Index, Index>>& broken) {
  if (!m_failure) return;
  // On a part a rank holds some families only, and every rank must search alike: not there.
  if (!m_graph_parts && std::all_of(broken.begin(), broken.end(), [&](const std::pair<Index, Index>& p) {
        return joined_round(p.first, p.second);
      }))
    return;
  update(contact);
}

bool FragmentTracker::joined_round(Index i, Index j) const {
  const Bonds& bonds = m_model.bonds;
  const std::span<const double> intact = m_failure->weights();
  for (Index b = bonds.start[i]; b < bonds.start[i + 1]; ++b) {
    if (intact[b] == 0.0) continue;
    const Index k = bonds.neighbour[b];
    for (Index c = bonds.start[j]; c < bonds.start[j + 1]; ++c)
      if (bonds.neighbour[c] == k && intact[c] != 0.0) return true;
  }
  return false;
}

void FragmentTracker::update(ContactSystem* contact) {
  if (!m_failure) return;
  ++m_graph_searches;
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
    if (m_options.rows.counts(i)) {  // its own particles (every one in one process), summed below
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
  // The components (by global id on a part): every rank's own particles' components, once.
  std::vector<Index> every = m_ranks.all_gather(roots);
  std::sort(every.begin(), every.end());
  m_fragments = static_cast<Index>(std::unique(every.begin(), every.end()) - every.begin());
  m_fragment_particles = static_cast<Index>(m_ranks.sum(std::int64_t{m_fragment_particles}));
  if (contact) contact->set_excluded(m_fragment_particles > 0 ? m_fragment : std::vector<char>{});
  m_failure->set_held(m_fragment_particles > 0 ? m_fragment : std::vector<char>{});
}

void FragmentTracker::hold(VectorXd& force) {
  Vec2 reaction = Vec2::Zero();  // bonds inside a fragment cancel: what remains is contact
  for (const Index c : m_fragment_components) {
    if (m_options.rows.counts(c / 2)) reaction[c % 2] += force[c];
    force[c] = 0.0;
  }
  // The sum over the ranks' own particles (collective: every rank knows that fragments exist).
  if (m_fragment_particles > 0) m_ranks.sum_in_rank_order(std::span<double>(reaction.data(), 2));
  m_fragment_reaction = reaction.norm();
}

Index FragmentTracker::contacts(const ContactSystem* contact) const {
  if (!contact || m_fragment_particles == 0) return 0;
  Index n = 0;
  for (std::size_t c = 0; c < m_fragment_components.size(); c += 2) {
    const Index i = m_fragment_components[c] / 2;
    if (!m_options.rows.counts(i)) continue;  // its own particles, summed over the ranks
    for (auto* e = contact->incident_begin(i); e != contact->incident_end(i); ++e)
      if (!m_fragment[e->other] && contact->result(e->pair).status != PairStatus::open) ++n;
  }
  return static_cast<Index>(m_ranks.sum(std::int64_t{n}));
}

void FragmentTracker::decouple(SparseMatrix& K) const {
  if (m_fragment_unknowns.empty()) return;
  // A rank's K holds its own rows only: the largest diagonal is the ranks' (the same number
  // on every rank, as in one process).
  double d = K.diagonal().cwiseAbs().maxCoeff();
  d = m_ranks.max(d);
  // The fragments' rows and columns zero, their diagonal d. Every stored entry is visited: a
  // rank's K holds row f only in the columns of f's couplings, which column f (holding the
  // rank's rows only) does not list.
  const std::vector<char>& fragment = m_fragment_unknown;
#pragma omp parallel for schedule(static)
  for (Index col = 0; col < static_cast<Index>(K.outerSize()); ++col)
    for (SparseMatrix::InnerIterator it(K, col); it; ++it)
      if (fragment[col] || fragment[it.row()]) it.valueRef() = it.row() == col ? d : 0.0;
}

std::size_t FragmentTracker::memory_bytes() const {
  return m_initially_unsupported.capacity() + m_fragment.capacity() + m_unsupported.capacity() +
         m_fragment_unknown.capacity() +
         (m_component.capacity() + m_fragment_unknowns.capacity() + m_fragment_components.capacity()) *
             sizeof(Index);
}

}  // namespace peristat
