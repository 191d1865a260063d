#include "materials/bond_failure.hpp"

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <numbers>
#include <numeric>
#include <stdexcept>
#include <tuple>

#include "core/error.hpp"
#include "materials/failure.hpp"
#include "materials/osb.hpp"

namespace peristat {

BondFailure::BondFailure(const Model& model, const FailureOptions& options, const Ranks& ranks,
                         FailureRanks share)
    : m_model(model),
      m_options(options),
      m_ranks(ranks),
      m_share(std::move(share)),
      m_min_sin(std::sin(options.skew_min_angle * std::numbers::pi / 180.0)),
      m_weight(model.bonds.every_weight()) {
  const Bonds& bonds = model.bonds;
  const Index n = model.particles.size();
  for (const BodyInfo& body : model.bodies) {
    const double mu = shear_modulus(body.material);
    m_critical.push_back(
        options.criterion == FailureCriterion::skew
            ? options.skew_scale * critical_skew(options.G_c, mu, model.horizon)
            : critical_stretch(options.G_c, bulk_modulus_2d(body.material), mu, model.horizon));
  }
  if (options.criterion == FailureCriterion::skew) {
    m_reference_bond.assign(n, -1);
    for (Index i = 0; i < n; ++i) {
      const Index b0 = bonds.start[i];
      const Index r = reference_bond(model.family_xi(i), options.direction);
      if (r >= 0) m_reference_bond[i] = b0 + r;
    }
  }
  m_ratio.assign(bonds.neighbour.size(), 0.0);
  number_particles(n);
}

void BondFailure::number_particles(Index n) {
  const Model& model = m_model;
  if (!m_share.ids) {  // a whole model: one process's, numbered by itself
    if (!model.holds_every_family())
      throw std::logic_error("BondFailure: a model holding some families only must be a rank's part (global ids)");
    if (m_ranks.size() > 1)
      throw std::logic_error("BondFailure: a model without global ids is one process's, not one of " +
                             std::to_string(m_ranks.size()) + " ranks'");
    m_share.proposes.assign(static_cast<std::size_t>(n), 1);
    m_own = GlobalIds(n);
  }
  if (m_share.proposes.size() != static_cast<std::size_t>(n) || ids().size() != n || ids().n_whole() <= 0 ||
      (!model.holds_every_family() && !m_share.share))
    throw std::logic_error(
        "BondFailure: a rank's part needs its share (FailureRanks: proposers, global ids, the particle exchange)");
  // A whole model holds every family, and its bonds are the whole model's.
  m_held = model.holds_every_family() ? std::vector<char>(static_cast<std::size_t>(n), 1) : model.family_held;
  m_whole_start = model.whole_start.empty() ? std::vector<std::int64_t>(model.bonds.start.begin(), model.bonds.start.end())
                                            : model.whole_start;
  if (m_whole_start.size() != static_cast<std::size_t>(n) + 1)
    throw std::logic_error("BondFailure: a part needs the whole model's family starts");
}

const std::vector<std::pair<Index, Index>>& BondFailure::break_over_criterion(std::span<const Vec2> eta,
                                                                              Index at_most) {
  // A round is what this call breaks: between converged equilibria every round is committed
  // or reverted before the next; ADR breaking during its iterations calls this at every step.
  m_round_pairs = 0;
  m_round.clear();
  m_round_bonds.clear();
  m_round_references.clear();
  const Bonds& bonds = m_model.bonds;
  const Particles& p = m_model.particles;
  const Index n = p.size();
  const bool skew = m_options.criterion == FailureCriterion::skew;
#pragma omp parallel for schedule(static)
  for (Index i = 0; i < n; ++i) {
    const Index b0 = bonds.start[i], nb = bonds.family_size(i);
    const double critical = m_critical[p.body[i]];
    if (skew) {
      if (m_reference_bond[i] < 0) continue;
      bond_skews(m_model.family_xi(i), eta.subspan(b0, nb), m_reference_bond[i] - b0, m_min_sin,
                 std::span(m_ratio).subspan(b0, nb));
      for (Index b = b0; b < b0 + nb; ++b) m_ratio[b] /= critical;
    } else {
      for (Index b = b0; b < b0 + nb; ++b) m_ratio[b] = bond_stretch(m_model.xi(i, b), eta[b]) / critical;
    }
  }
  // The pairs over the criterion, proposed by the ranks that hold their first particle's
  // family and gathered on every rank (one process: its own), broken alike everywhere.
  gather_candidates();
  if (m_candidates.empty()) return m_round;
  // Every rank sorts every rank's candidates by ratio, then by the whole model's bond index
  // b = whole_start[i] + k, that is by (i, k), both descending.
  std::sort(m_candidates.begin(), m_candidates.end(), [](const Candidate& a, const Candidate& b) {
    return std::tuple(a.ratio, a.i, a.k) > std::tuple(b.ratio, b.i, b.k);
  });
  const std::size_t count = pairs_to_break(m_candidates.size(), at_most);
  for (std::size_t c = 0; c < count; ++c) break_candidate(m_candidates[c]);
  reselect_references();
  return m_round;
}

namespace {
/// Particles per block of gather_candidates(): fixed, so that the blocks, and the order their
/// candidates are joined in, do not depend on the threads.
constexpr Index kCandidateBlock = 256;
}  // namespace

void BondFailure::gather_candidates() {
  // Each rank proposes the pairs (i, j > i) of the families it is the proposer of, the same
  // pairs one process loops over (b < reverse(i, b)). Particles go by their whole model's index
  // (global(), the part's own index otherwise). On the threads, block by block of particles;
  // the blocks' candidates joined in block order, their peaks by the rule of one loop (the
  // largest ratio, the smallest (i, k) among equals): the same candidates and peak as one
  // loop over the particles, on any number of threads.
  const Bonds& bonds = m_model.bonds;
  const Particles& p = m_model.particles;
  const Index n = p.size();
  const Index blocks = (n + kCandidateBlock - 1) / kCandidateBlock;
  std::vector<std::vector<Candidate>> found(static_cast<std::size_t>(blocks));
  std::vector<RankPeak> peaks_of(static_cast<std::size_t>(blocks), RankPeak{0.0, -1, -1, -1, 0.0, 0.0});
  const auto better = [](const RankPeak& a, const RankPeak& b) {
    return a.ratio > b.ratio || (a.ratio == b.ratio && b.i >= 0 && std::pair(a.i, a.k) < std::pair(b.i, b.k));
  };
  bool unpaired = false;
#pragma omp parallel for schedule(dynamic, 1) reduction(|| : unpaired)
  for (Index block = 0; block < blocks; ++block) {
    std::vector<Candidate>& mine = found[static_cast<std::size_t>(block)];
    RankPeak& peak = peaks_of[static_cast<std::size_t>(block)];
    for (Index i = block * kCandidateBlock; i < std::min(n, (block + 1) * kCandidateBlock); ++i) {
      if (!m_share.proposes[static_cast<std::size_t>(i)]) continue;
      const std::int64_t gi = global(i);
      for (Index b = bonds.start[i]; b < bonds.start[i + 1]; ++b) {
        const Index j = bonds.neighbour[b];
        const std::int64_t gj = global(j);
        if (gj < gi || m_weight[b] == 0.0) continue;
        if (p.fictitious[i] && p.fictitious[j]) continue;
        if (!m_held_particle.empty() && (m_held_particle[i] || m_held_particle[j])) continue;
        const Index r = bonds.reverse(i, b);
        if (r < 0) {
          unpaired = true;
          continue;
        }
        const double ratio = std::max(m_ratio[b], m_ratio[r]);
        const Index k = b - bonds.start[i];
        // One process keeps the first bond of the largest ratio: the smallest (i, k).
        const RankPeak here{ratio, gi, k, gj, 0.0, 0.0};
        if (better(here, peak)) {
          const Vec2 at = p.position[i] + 0.5 * Vec2(p.position[j] - p.position[i]);
          peak = RankPeak{ratio, gi, k, gj, at.x(), at.y()};
        }
        if (ratio <= 1.0) continue;
        mine.push_back(
            {ratio, gi, k, gj, r - bonds.start[j], m_whole_start[static_cast<std::size_t>(i)] + k});
      }
    }
  }
  if (unpaired)
    throw std::logic_error("BondFailure: the proposer of a pair does not hold its reverse family");
  std::vector<Candidate> mine;
  RankPeak peak{0.0, -1, -1, -1, 0.0, 0.0};
  for (Index block = 0; block < blocks; ++block) {
    const std::vector<Candidate>& f = found[static_cast<std::size_t>(block)];
    mine.insert(mine.end(), f.begin(), f.end());
    if (better(peaks_of[static_cast<std::size_t>(block)], peak))
      peak = peaks_of[static_cast<std::size_t>(block)];
  }
  m_candidates = m_ranks.all_gather(mine);
  // The peak over the ranks, in rank order, with the same tie-break.
  const std::vector<RankPeak> peaks = m_ranks.all_gather(std::span<const RankPeak>(&peak, 1));
  m_peak = Peak{};
  std::int64_t peak_k = -1;
  for (const RankPeak& q : peaks) {
    if (q.i >= 0 && (q.ratio > m_peak.ratio ||
                     (q.ratio == m_peak.ratio && std::pair(q.i, q.k) < std::pair<std::int64_t, std::int64_t>(
                                                                             m_peak.i, peak_k)))) {
      m_peak = Peak{q.ratio, static_cast<Index>(q.i), static_cast<Index>(q.j), Vec2(q.x, q.y)};
      peak_k = q.k;
    }
  }
}

void BondFailure::break_candidate(const Candidate& x) {
  const Bonds& bonds = m_model.bonds;
  const std::vector<char>& held = m_held;
  const Index i = local(x.i), j = local(x.j);
  const Index bi = i >= 0 && held[static_cast<std::size_t>(i)] ? bonds.start[i] + x.k : -1;
  const Index bj = j >= 0 && held[static_cast<std::size_t>(j)] ? bonds.start[j] + x.kr : -1;
  PERISTAT_ASSERT(bi < 0 || bonds.neighbour[bi] == j);
  PERISTAT_ASSERT(bj < 0 || bonds.neighbour[bj] == i);
  m_broken_whole.push_back(x.whole);
  if (bi < 0 && bj < 0) {  // far from this part: counted, nothing held
    ++m_round_pairs;
    ++m_broken;
    return;
  }
  break_pair(i, bi, j, bj);
}

std::size_t BondFailure::pairs_to_break(std::size_t over, Index at_most) const {
  // The most critical `fraction` of the pairs over the criterion, at least one, at most at_most.
  auto count = std::max<std::size_t>(1, static_cast<std::size_t>(std::ceil(m_options.fraction * static_cast<double>(over))));
  return at_most > 0 ? std::min(count, static_cast<std::size_t>(at_most)) : count;
}

void BondFailure::break_pair(Index i, Index bi, Index j, Index bj) {
  for (const auto& [particle, b] : {std::pair(i, bi), std::pair(j, bj)}) {
    if (b < 0) continue;
    m_weight[b] = 0.0;
    m_round_bonds.emplace_back(particle, b);
  }
  m_round.emplace_back(i, j);
  ++m_round_pairs;
  ++m_broken;
}

void BondFailure::reselect_references() {
  if (m_options.criterion != FailureCriterion::skew) return;
  // A particle whose reference bond broke measures its skew against the closest intact
  // bond from now on: the broken one's rotation contains the crack's slip.
  const Bonds& bonds = m_model.bonds;
  for (const auto& [i, c] : m_round_bonds) {
    if (m_reference_bond[i] != c) continue;
    const Index b0 = bonds.start[i], nb = bonds.family_size(i);
    const Index r = reference_bond(m_model.family_xi(i), m_options.direction,
                                   std::span<const double>(m_weight).subspan(b0, nb));
    m_round_references.emplace_back(i, c);
    m_reference_bond[i] = r >= 0 ? b0 + r : -1;
  }
}

void BondFailure::commit() {
  m_round_pairs = 0;
  m_round.clear();
  m_round_bonds.clear();
  m_round_references.clear();
}

void BondFailure::revert() {
  const Bonds& bonds = m_model.bonds;
  for (const auto& [particle, b] : m_round_bonds) m_weight[b] = bonds.weight(particle, b);
  m_broken -= m_round_pairs;
  m_broken_whole.resize(m_broken_whole.size() - static_cast<std::size_t>(m_round_pairs));
  for (auto it = m_round_references.rbegin(); it != m_round_references.rend(); ++it)
    m_reference_bond[it->first] = it->second;
  commit();
}

void BondFailure::damage(VectorXd& d) const {
  const Bonds& bonds = m_model.bonds;
  const Index n = m_model.particles.size();
  d.resize(n);
  for (Index i = 0; i < n; ++i) {
    double all = 0.0, intact = 0.0;
    const std::span<const double> w = bonds.weights(i);
    for (Index b = bonds.start[i]; b < bonds.start[i + 1]; ++b) {
      all += w[static_cast<std::size_t>(b - bonds.start[i])];
      intact += m_weight[b];
    }
    d[i] = all > 0.0 ? 1.0 - intact / all : 0.0;
  }
  // A family this rank does not hold has damage 0 here: its owner's value replaces it (a
  // model holding every family has no exchange).
  if (m_share.share) m_share.share->share(d.data());
}

void BondFailure::save(StateArchive& archive) const {
  // The broken pairs by the whole model's index of their first bond, ascending.
  std::vector<std::int64_t> sorted = m_broken_whole;
  std::sort(sorted.begin(), sorted.end());
  archive.put("failure/broken_bonds", std::vector<double>(sorted.begin(), sorted.end()));
  if (m_reference_bond.empty()) return;
  // The whole model's index of each reference bond, from the rank that proposes its family,
  // to rank 0 by global id.
  const Bonds& bonds = m_model.bonds;
  std::vector<std::int64_t> ids, values;
  for (Index i = 0; i < m_model.particles.size(); ++i) {
    if (!m_share.proposes[static_cast<std::size_t>(i)]) continue;
    ids.push_back(global(i));
    values.push_back(m_reference_bond[i] < 0
                         ? -1
                         : m_whole_start[static_cast<std::size_t>(i)] + m_reference_bond[i] - bonds.start[i]);
  }
  const std::vector<std::int64_t> table = m_ranks.gather_rows_on_root(
      std::span<const std::int64_t>(ids), std::span<const std::int64_t>(values), 1, this->ids().n_whole());
  archive.put("failure/reference_bonds", {table.begin(), table.end()});  // the file holds doubles
}

namespace {
std::int64_t whole_index(double value, std::int64_t lo, std::int64_t hi, const std::string& key) {
  if (!(value >= static_cast<double>(lo) && value < static_cast<double>(hi)) ||
      value != static_cast<double>(static_cast<std::int64_t>(value)))
    throw InputError("the checkpoint's '" + key + "' holds an index out of range");
  return static_cast<std::int64_t>(value);
}
}  // namespace

std::vector<BondFailure::Candidate> BondFailure::restored_pairs(const std::vector<double>& broken) const {
  // Each pair is resolved by the rank that proposes its first particle's family (it holds
  // both directions). The proposed families by the whole index of their first bond (on a part
  // not in that order).
  const Bonds& bonds = m_model.bonds;
  std::vector<std::pair<std::int64_t, Index>> first;
  for (Index i = 0; i < m_model.particles.size(); ++i)
    if (m_share.proposes[static_cast<std::size_t>(i)] && bonds.family_size(i) > 0)
      first.emplace_back(m_whole_start[static_cast<std::size_t>(i)], i);
  std::sort(first.begin(), first.end());
  std::vector<Candidate> mine;  // ratio: the pair's position in the checkpoint
  for (std::size_t at = 0; at < broken.size(); ++at) {
    const std::int64_t w = whole_index(broken[at], 0, m_model.n_bonds_whole, "failure/broken_bonds");
    auto it = std::upper_bound(first.begin(), first.end(), std::pair(w, std::numeric_limits<Index>::max()));
    if (it == first.begin()) continue;
    --it;
    const Index i = it->second;
    if (w >= it->first + bonds.family_size(i)) continue;  // another rank's family
    const Index b = bonds.start[i] + static_cast<Index>(w - it->first);
    const Index j = bonds.neighbour[b], r = bonds.reverse(i, b);
    if (global(j) < global(i) || r < 0) throw InputError("the checkpoint's 'failure/broken_bonds' holds a bond twice");
    mine.push_back({static_cast<double>(at), global(i), b - bonds.start[i], global(j), r - bonds.start[j], w});
  }
  const std::vector<Candidate> all = m_ranks.all_gather(mine);
  if (all.size() != broken.size()) throw InputError("the checkpoint's 'failure/broken_bonds' holds a bond twice");
  std::vector<Candidate> pairs(broken.size());
  std::vector<char> seen(broken.size(), 0);
  for (const Candidate& x : all) {
    const auto k = static_cast<std::size_t>(x.ratio);
    if (seen[k]++) throw InputError("the checkpoint's 'failure/broken_bonds' holds a bond twice");
    pairs[k] = x;
    pairs[k].ratio = 0.0;
  }
  return pairs;
}

std::vector<std::pair<Index, Index>> BondFailure::restore(const StateArchive& archive) {
  const Bonds& bonds = m_model.bonds;
  for (const Candidate& x : restored_pairs(archive.get("failure/broken_bonds"))) break_candidate(x);
  if (!m_reference_bond.empty()) {
    const std::vector<double>& r = archive.get("failure/reference_bonds", ids().n_whole());
    for (std::size_t i = 0; i < m_reference_bond.size(); ++i) {
      const double ri = r[static_cast<std::size_t>(global(static_cast<Index>(i)))];
      if (ri < 0) {
        m_reference_bond[i] = -1;
      } else if (m_held[i]) {  // the other families' references are never read here
        const auto l = static_cast<Index>(i);
        const std::int64_t first = m_whole_start[i];
        const std::int64_t w = whole_index(ri, first, first + bonds.family_size(l), "failure/reference_bonds");
        m_reference_bond[i] = bonds.start[l] + static_cast<Index>(w - first);
      }
    }
  }
  std::vector<std::pair<Index, Index>> restored = std::move(m_round);
  m_round.clear();
  commit();
  return restored;
}

std::size_t BondFailure::memory_bytes() const {
  return (m_critical.capacity() + m_weight.capacity() + m_ratio.capacity()) * sizeof(double) +
         m_reference_bond.capacity() * sizeof(Index) +
         m_round_references.capacity() * sizeof(std::pair<Index, Index>) +
         (m_broken_whole.capacity() + m_whole_start.capacity()) * sizeof(std::int64_t) +
         m_held.capacity() + m_share.proposes.capacity() + m_own.memory_bytes();
}

}  // namespace peristat
