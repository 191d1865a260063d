// Tpetra's start, and the MPI reductions, exchanges and gathers that the program still calls
// as free functions (they move behind `Ranks`, src/parallel). MPI itself starts and ends in
// src/parallel/mpi/session.hpp.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "parallel/mpi/session.hpp"

namespace peristat::parallel {

/// Starts MPI (src/parallel/mpi: a quiet singleton in a plain process) and Tpetra on it, when
/// they are not running yet; Tpetra ends before MPI does.
void ensure_started();
/// This process's rank and the number of ranks (0 and 1 before MPI starts).
int rank();
int size();
/// The largest value and the sum over every rank (collective: every rank calls them at the
/// same point); the value itself in one process.
double max_over_ranks(double value);
long long sum_over_ranks(long long value);
/// Sums values[0 .. n) over the ranks in place, adding the ranks' values in rank order on
/// every rank, so that every rank gets the same bits (an MPI_Allreduce need not).
void sum_in_rank_order(double* values, int n);
double sum_over_ranks(double value);
/// Every rank's `mine` concatenated in rank order, on every rank (MPI_Allgather of the
/// counts, then MPI_Allgatherv); `mine` itself in one process.
std::vector<double> gather_over_ranks(const std::vector<double>& mine);

/// Copies every rank's own entries of a vector into every rank's copy (distributed ADR; the
/// forces of partitioned bonds): entry k belongs to rank owner[k], a table every rank holds
/// alike. An entry without an owner (-1) is refused, or with `keep_unowned` left as each rank
/// has it. Buffers are made once; share() is collective.
class OwnedExchange {
 public:
  explicit OwnedExchange(const std::vector<int>& owner, bool keep_unowned = false);
  void share(double* x);

 private:
  int m_rank = 0;
  std::vector<int> m_counts, m_displs;  ///< entries per rank, and where each rank's begin
  std::vector<long long> m_order;       ///< the entries, rank by rank, ascending within a rank
  std::vector<double> m_send, m_received;
};
/// Values that each rank sends to the ranks that read them and receives from the ranks that
/// own them, in one MPI_Alltoallv per share(): what GhostExchange and PartExchange build.
class Halo {
 public:
  /// Collective: this rank's entries that others read go to them; its ghost entries are filled.
  void share(double* x);
  /// Entries share() fills here: this rank's halo.
  std::size_t ghosts() const { return m_recv_index.size(); }

 protected:
  /// With m_recv_counts set (per owner rank, the entries this rank receives) and `asked` (what
  /// names them to their owners, grouped by owner): tells every owner what this rank reads
  /// (one MPI_Alltoall, one MPI_Alltoallv) and returns what the others read of this rank's,
  /// grouped by reader; sets the displacements, the send counts and the buffers.
  std::vector<long long> ask_owners(const std::vector<long long>& asked);

  std::vector<int> m_send_counts, m_send_displs, m_recv_counts, m_recv_displs;
  std::vector<std::size_t> m_send_index, m_recv_index;  ///< rank by rank: entries sent, entries filled
  std::vector<double> m_send, m_received;
};

/// Copies into each rank's copy of a vector the entries it reads and does not own, from their
/// owners (distributed ADR between pseudo-time steps: a rank's rows read its ghosts, not every
/// entry): entry k belongs to rank owner[k] (a table every rank holds alike), `reads` lists
/// the entries this rank reads (its own among them are skipped). The construction is
/// collective (each rank tells the owners what it reads); share() is collective, one
/// MPI_Alltoallv of the ghosts' values.
class GhostExchange : public Halo {
 public:
  GhostExchange(const std::vector<int>& owner, const std::vector<long long>& reads);
};

/// The ghost tail of a vector over a rank's part of the model (ModelPart, docs/guide/distributed.md
/// "The partitioned model"): entries [0, n_owned) are this rank's, entry k >= n_owned is the
/// entry of global id ids[k] owned by rank owner[k], where it sits among that rank's first
/// entries. No table over the whole model: the construction sends each owner the ids a rank
/// reads (collective, one MPI_Alltoall and one MPI_Alltoallv), and every owner finds them among
/// its owned ids, which must ascend. share() is collective: one MPI_Alltoallv of the ghosts'
/// values. Throws std::logic_error when a rank asks for an id its owner does not own.
class PartExchange : public Halo {
 public:
  PartExchange(const std::vector<std::int64_t>& ids, const std::vector<int>& owner, std::size_t n_owned);
};

/// The sum of `value` over the ranks before this one (0 on rank 0), and over every rank:
/// the first global number of this rank's items when each rank numbers its own in turn.
std::int64_t sum_over_lower_ranks(std::int64_t value, std::int64_t* total);

/// Rank 0 receives every rank's rows of a table spread over the ranks by global id (the output
/// of a run on the parts, docs/guide/distributed.md "The partitioned model"): each rank gives
/// the ids of its rows and `width` values per row, row by row; rank 0 returns the n_rows x
/// width table (row-major) with each row at its id, the other ranks an empty vector.
/// Collective (one MPI_Gather of the counts, two MPI_Gatherv). Throws std::logic_error on rank
/// 0 when the ranks' ids do not cover [0, n_rows) once each, std::length_error past 2^31 values.
std::vector<double> gather_rows_on_root(const std::vector<std::int64_t>& ids,
                                        const std::vector<double>& values, int width, std::int64_t n_rows);
/// The inverse for a table every rank holds alike (a checkpoint's state read on every rank):
/// the rows `ids` of `table` (n_rows x width, row-major), row by row. No communication.
std::vector<double> rows_of(const std::vector<double>& table, int width,
                            const std::vector<std::int64_t>& ids);

}  // namespace peristat::parallel
