// P ranks emulated by P threads of one process, for the unit tests of code that takes a
// `Ranks`: each rank runs on its own thread, and every collective meets at a barrier as MPI's
// do, so a rank's later decisions may depend on what the others sent. The same `Ranks`
// templates (reductions in rank order, gathers, halo exchanges) run on these as on MPI.
#pragma once

#include <barrier>
#include <functional>
#include <vector>

#include "parallel/ranks.hpp"

namespace peristat {

class ThreadRanks;

/// The meeting point of the emulated ranks: run(body) starts one thread per rank.
class ThreadNet {
 public:
  explicit ThreadNet(int ranks);
  int size() const { return m_ranks; }
  /// Runs body(ranks) on one thread per rank (each with one OpenMP thread) and waits for all.
  /// A rank that throws leaves the collectives (the others go on without it), and the first
  /// exception is rethrown here.
  void run(const std::function<void(const ThreadRanks& ranks)>& body);

 private:
  friend class ThreadRanks;
  /// What one rank posts for a collective: its buffer, count and, for all_to_all_v, its
  /// per-destination counts.
  struct Slot {
    const void* data = nullptr;
    std::int64_t n = 0;
    std::span<const std::int64_t> counts;
  };
  int m_ranks;
  std::barrier<> m_barrier;
  std::vector<Slot> m_slots;
};

class ThreadRanks final : public Ranks {
 public:
  ThreadRanks(ThreadNet& net, int rank) : m_net(net), m_rank(rank) {}
  int rank() const override { return m_rank; }
  int size() const override { return m_net.m_ranks; }
  std::vector<std::int64_t> all_gather_counts(std::int64_t mine) const override;
  void all_gather_v(const void* mine, std::int64_t n, void* all, std::span<const std::int64_t> counts,
                    std::size_t bytes) const override;
  void gather_v(const void* mine, std::int64_t n, void* all, std::span<const std::int64_t> counts,
                std::size_t bytes) const override;
  void broadcast_raw(void* data, std::int64_t n, std::size_t bytes) const override;
  void all_to_all_v(const void* send, std::span<const std::int64_t> send_counts, void* recv,
                    std::span<const std::int64_t> recv_counts, std::size_t bytes) const override;

 private:
  /// Posts this rank's slot, waits for every rank's, lets `read` copy from them, and waits
  /// again so that no slot is reused before every rank has read.
  template <class Read>
  void meet(const ThreadNet::Slot& mine, Read&& read) const;

  ThreadNet& m_net;
  int m_rank;
};

}  // namespace peristat
