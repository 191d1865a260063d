#include "app/unknown_share.hpp"

#include <algorithm>
#include <memory>

#include "parallel/exchange.hpp"

namespace peristat {

namespace {

/// On a part: the problem imports the ghost tail of every state it evaluates; the other
/// vectors (the pseudo-velocity, x at the end of a solve) go through its exchange too.
class PartUnknowns final : public UnknownExchange {
 public:
  explicit PartUnknowns(QuasiStaticProblem& problem) : m_problem(problem) {}
  void share_all(VectorXd& x) override { m_problem.import_ghosts(x); }
  void share_reads(VectorXd& x) override { m_problem.import_ghosts(x); }
  std::size_t memory_bytes() const override { return 0; }  // the problem's exchange, counted there

 private:
  QuasiStaticProblem& m_problem;
};

/// The whole model on the ranks: every owned entry to every rank, or the entries the own rows
/// read; the latter rebuilt (collectively: every rank sees the same contact version) when a
/// partner search changed the pairs.
class WholeUnknowns final : public UnknownExchange {
 public:
  WholeUnknowns(QuasiStaticProblem& problem, std::vector<int> owner)
      : m_problem(problem), m_owner(std::move(owner)), m_all(problem.ranks(), m_owner) {}
  void share_all(VectorXd& x) override { m_all.share(x.data()); }
  void share_reads(VectorXd& x) override {
    if (!m_reads || m_version != m_problem.traits().structure_version) {
      const std::vector<Index> reads = m_problem.residual_reads();
      m_reads = std::make_unique<GhostExchange>(m_problem.ranks(), m_owner,
                                                std::vector<std::int64_t>(reads.begin(), reads.end()));
      m_version = m_problem.traits().structure_version;
    }
    m_reads->share(x.data());
  }
  std::size_t memory_bytes() const override {
    return m_owner.capacity() * sizeof(int) + m_all.memory_bytes() + (m_reads ? m_reads->memory_bytes() : 0);
  }

 private:
  QuasiStaticProblem& m_problem;
  std::vector<int> m_owner;
  OwnedExchange m_all;  // throws for an unknown without owner
  std::unique_ptr<GhostExchange> m_reads;
  std::uint64_t m_version = 0;
};

}  // namespace


UnknownShare part_unknown_share(QuasiStaticProblem& problem, const ModelPart& part) {
  UnknownShare share;
  share.ranks = &problem.ranks();
  share.owned.assign(static_cast<std::size_t>(part.model.constraints.n_free), 0);
  std::fill_n(share.owned.begin(), part.n_owned_unknowns, char{1});
  share.exchange = std::make_unique<PartUnknowns>(problem);
  share.problem_imports_state = true;
  return share;
}

UnknownShare unknown_share(QuasiStaticProblem& problem) {
  const OwnedRows& rows = problem.owned_rows();
  UnknownShare share;
  if (rows.all()) return share;
  std::vector<int> owner = unknown_owners(problem.model().constraints, rows.owner);
  share.ranks = &problem.ranks();
  share.owned.resize(owner.size());
  for (std::size_t f = 0; f < owner.size(); ++f) share.owned[f] = owner[f] == rows.rank;
  share.exchange = std::make_unique<WholeUnknowns>(problem, std::move(owner));
  return share;
}

}  // namespace peristat
