// The ranks of a distributed run emulated by the threads of one process, for unit tests of
// code that takes its collective operations as functions (ProblemOptions, FailureRanks): each
// rank runs on its own thread and the operations meet at a barrier, as MPI's collectives do,
// so a rank's later decisions may depend on what the others sent. The unit tier stays MPI-free.
#pragma once

#include <barrier>
#include <cstddef>
#include <functional>
#include <vector>

#include "discretisation/model.hpp"

namespace peristat::test {

/// Owners by x: the particles that have an unknown, ordered by x (then by index), in `ranks`
/// ranges of equal count (where RCB's first cut falls on the test plates; strip_owners()
/// gives the strips by particle index).
std::vector<int> x_cut_owners(const Model& model, int ranks);

class EmulatedRanks {
 public:
  explicit EmulatedRanks(int ranks);
  int size() const { return m_ranks; }
  /// Runs body(rank) on one thread per rank (each with one OpenMP thread) and waits for all.
  /// A rank that throws leaves the collectives (the others go on without it), and the first
  /// exception is rethrown here.
  void run(const std::function<void(int rank)>& body);

  // Collective operations: every rank calls them at the same point.
  /// Every rank's `mine` in rank order.
  std::vector<double> gather(int rank, const std::vector<double>& mine);
  /// The sum in rank order, and the largest value.
  double sum(int rank, double value);
  double max(int rank, double value);
  /// Copies each entry k of x[0 .. n) from the copy of rank owner[k] into every rank's x;
  /// entries without an owner (-1) stay as each rank has them.
  void share(int rank, const std::vector<int>& owner, double* x, std::size_t n);

 private:
  int m_ranks;
  std::barrier<> m_barrier;
  std::vector<std::vector<double>> m_slots;
};

}  // namespace peristat::test
