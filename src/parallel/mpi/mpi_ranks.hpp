// The ranks of a run under mpirun: MPI_COMM_WORLD behind the `Ranks` interface. With
// session.hpp, the only room of the program that includes mpi.h besides the Trilinos adapter.
#pragma once

#include <memory>

#include "parallel/mpi/session.hpp"
#include "parallel/ranks.hpp"

namespace peristat::parallel {

/// This process's ranks: MPI_COMM_WORLD's when MPI runs with more than one rank, else one
/// process's (SerialRanks). Made once per run, in src/app.
std::unique_ptr<Ranks> process_ranks();

/// MPI_COMM_WORLD (MPI must run).
class MpiRanks final : public Ranks {
 public:
  MpiRanks();
  int rank() const override { return m_rank; }
  int size() const override { return m_size; }
  std::vector<std::int64_t> all_gather_counts(std::int64_t mine) const override;
  void all_gather_v(const void* mine, std::int64_t n, void* all, std::span<const std::int64_t> counts,
                    std::size_t bytes) const override;
  void gather_v(const void* mine, std::int64_t n, void* all, std::span<const std::int64_t> counts,
                std::size_t bytes) const override;
  void broadcast_raw(void* data, std::int64_t n, std::size_t bytes) const override;
  void all_to_all_v(const void* send, std::span<const std::int64_t> send_counts, void* recv,
                    std::span<const std::int64_t> recv_counts, std::size_t bytes) const override;

 private:
  int m_rank = 0, m_size = 1;
};

}  // namespace peristat::parallel
