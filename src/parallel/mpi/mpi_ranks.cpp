#include "parallel/mpi/mpi_ranks.hpp"

#include <limits>
#include <map>
#include <mutex>
#include <stdexcept>
#include <string>
#include <vector>

#include <mpi.h>

namespace peristat::parallel {

namespace {

int as_int(std::int64_t n, const char* what) {
  if (n > std::numeric_limits<int>::max())
    throw std::length_error(std::string(what) + ": more than 2^31 elements in one message");
  return static_cast<int>(n);
}

/// A contiguous type of `bytes` bytes, made once per size (the collectives count elements).
MPI_Datatype element_type(std::size_t bytes) {
  static std::mutex guard;
  static std::map<std::size_t, MPI_Datatype> types;
  const std::lock_guard<std::mutex> lock(guard);
  auto it = types.find(bytes);
  if (it == types.end()) {
    MPI_Datatype t;
    MPI_Type_contiguous(static_cast<int>(bytes), MPI_BYTE, &t);
    MPI_Type_commit(&t);
    it = types.emplace(bytes, t).first;
  }
  return it->second;
}

/// Counts and displacements as MPI's ints.
void counts_displs(std::span<const std::int64_t> counts, std::vector<int>& c, std::vector<int>& d,
                   const char* what) {
  c.resize(counts.size());
  d.assign(counts.size(), 0);
  std::int64_t total = 0;
  for (std::size_t p = 0; p < counts.size(); ++p) {
    c[p] = as_int(counts[p], what);
    d[p] = as_int(total, what);
    total += counts[p];
  }
  as_int(total, what);
}

}  // namespace

std::unique_ptr<Ranks> process_ranks() {
  if (started()) {
    int size = 1;
    MPI_Comm_size(MPI_COMM_WORLD, &size);
    if (size > 1) return std::make_unique<MpiRanks>();
  }
  return std::make_unique<SerialRanks>();
}

MpiRanks::MpiRanks() {
  if (!started()) throw std::logic_error("MpiRanks: MPI has not started");
  MPI_Comm_rank(MPI_COMM_WORLD, &m_rank);
  MPI_Comm_size(MPI_COMM_WORLD, &m_size);
}

std::vector<std::int64_t> MpiRanks::all_gather_counts(std::int64_t mine) const {
  std::vector<std::int64_t> counts(static_cast<std::size_t>(m_size));
  MPI_Allgather(&mine, 1, MPI_INT64_T, counts.data(), 1, MPI_INT64_T, MPI_COMM_WORLD);
  return counts;
}

void MpiRanks::all_gather_v(const void* mine, std::int64_t n, void* all, std::span<const std::int64_t> counts,
                            std::size_t bytes) const {
  std::vector<int> c, d;
  counts_displs(counts, c, d, "all_gather");
  MPI_Allgatherv(mine, as_int(n, "all_gather"), element_type(bytes), all, c.data(), d.data(), element_type(bytes),
                 MPI_COMM_WORLD);
}

void MpiRanks::gather_v(const void* mine, std::int64_t n, void* all, std::span<const std::int64_t> counts,
                        std::size_t bytes) const {
  std::vector<int> c, d;
  if (m_rank == 0) counts_displs(counts, c, d, "gather_to_root");
  MPI_Gatherv(mine, as_int(n, "gather_to_root"), element_type(bytes), all, c.data(), d.data(),
              element_type(bytes), 0, MPI_COMM_WORLD);
}

void MpiRanks::broadcast_raw(void* data, std::int64_t n, std::size_t bytes) const {
  MPI_Bcast(data, as_int(n, "broadcast"), element_type(bytes), 0, MPI_COMM_WORLD);
}

void MpiRanks::all_to_all_v(const void* send, std::span<const std::int64_t> send_counts, void* recv,
                            std::span<const std::int64_t> recv_counts, std::size_t bytes) const {
  std::vector<int> sc, sd, rc, rd;
  counts_displs(send_counts, sc, sd, "all_to_all");
  counts_displs(recv_counts, rc, rd, "all_to_all");
  MPI_Alltoallv(send, sc.data(), sd.data(), element_type(bytes), recv, rc.data(), rd.data(), element_type(bytes),
                MPI_COMM_WORLD);
}

}  // namespace peristat::parallel
