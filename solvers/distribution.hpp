// How the ranks of a distributed run share the unknowns, for a solver that updates each
// unknown on one rank and needs the unknowns its rows read from the ranks that own them
// (distributed ADR, docs/guide/distributed.md). The program makes it (src/app/unknown_share.cpp).
#pragma once

#include <memory>
#include <vector>

#include "core/types.hpp"
#include "parallel/ranks.hpp"

namespace peristat {

/// Moves the owners' values of the unknowns to the ranks that read them.
class UnknownExchange {
 public:
  virtual ~UnknownExchange() = default;
  /// Every entry of x this rank holds and does not own, from its owner (at the end of a solve).
  virtual void share_all(VectorXd& x) = 0;
  /// Only the entries this rank's own-rows evaluation reads (its ghosts: two horizons, contact
  /// pairs, mirror sources); the others go stale until the next share_all(). Between
  /// pseudo-time steps.
  virtual void share_reads(VectorXd& x) = 0;
  /// Bytes of its index lists and buffers.
  virtual std::size_t memory_bytes() const = 0;
};

struct UnknownShare {
  /// The ranks of the run; null: one process, every unknown here.
  const Ranks* ranks = nullptr;
  /// Per unknown: 1 when this rank updates it.
  std::vector<char> owned;
  std::unique_ptr<UnknownExchange> exchange;
  /// On a rank's part of the model (ModelPart): the owned unknowns come first and the problem
  /// imports the ghost tail of every state it evaluates, so the solver imports only the other
  /// vectors its residual reads (the pseudo-velocity), with share_reads.
  bool problem_imports_state = false;

  bool distributed() const { return ranks != nullptr; }
};

}  // namespace peristat
