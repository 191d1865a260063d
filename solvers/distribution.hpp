// How the ranks of a distributed run share the unknowns, for a solver that updates each
// unknown on one rank and needs every unknown on every rank between its updates (distributed
// ADR, docs/guide/distributed.md). Free of MPI: the program fills it (app/setup.cpp).
#pragma once

#include <functional>
#include <vector>

#include "core/types.hpp"

namespace peristat {

struct UnknownShare {
  /// Per unknown: 1 when this rank updates it. Empty: one process, every unknown here.
  std::vector<char> owned;
  /// Sums values[0 .. n) over the ranks in place, with the same result on every rank.
  std::function<void(double* values, int n)> sum;
  /// The largest of a value over the ranks.
  std::function<double(double)> max;
  /// Copies every rank's own entries of x into every rank's x.
  std::function<void(VectorXd& x)> share;
  /// Copies into this rank's x only the entries its own-rows evaluation reads (its ghosts:
  /// two horizons, contact pairs, mirror sources) from their owners; the others go stale until
  /// the next share(). Between pseudo-time steps.
  std::function<void(VectorXd& x)> share_reads;
  /// On a rank's part of the model (ModelPart): the owned unknowns come first and the problem
  /// imports the ghost tail of every state it evaluates, so the solver imports only the other
  /// vectors its residual reads (the pseudo-velocity), with share_reads.
  bool problem_imports_state = false;

  bool distributed() const { return !owned.empty(); }
};

}  // namespace peristat
