#include "app/unknown_share.hpp"

#include <algorithm>
#include <memory>

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

}  // namespace peristat
