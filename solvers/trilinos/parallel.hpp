// MPI for the distributed linear algebra, started and ended through Tpetra. peristat runs
// in one process unless it is launched by mpirun; then main() starts MPI at once, and every
// rank runs the same model while the linear solves are distributed (solver.linear: belos).
// In a plain process MPI starts only when a belos solver is made (an MPI singleton).
#pragma once

#include <vector>

namespace peristat::parallel {

/// True when this process was launched by mpirun (Open MPI's or another's environment).
bool launched_by_mpirun();

/// Starts MPI now if launched by mpirun; ends it (if started) when destroyed. One per
/// program, in main(), outliving every distributed object.
class Session {
 public:
  Session();
  ~Session();
  Session(const Session&) = delete;
  Session& operator=(const Session&) = delete;
};

/// Starts MPI when it is not running yet (a plain process: a singleton of one rank).
void ensure_started();
/// This process's rank and the number of ranks (0 and 1 before MPI starts).
int rank();
int size();
/// The ranks that share this machine's memory (1 before MPI starts).
int ranks_on_this_machine();
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
/// Copies into each rank's copy of a vector the entries it reads and does not own, from their
/// owners (distributed ADR between pseudo-time steps: a rank's rows read its ghosts, not every
/// entry): entry k belongs to rank owner[k] (a table every rank holds alike), `reads` lists
/// the entries this rank reads (its own among them are skipped). The construction is
/// collective (each rank tells the owners what it reads); share() is collective, one
/// MPI_Alltoallv of the ghosts' values.
class GhostExchange {
 public:
  GhostExchange(const std::vector<int>& owner, const std::vector<long long>& reads);
  void share(double* x);

 private:
  std::vector<int> m_send_counts, m_send_displs, m_recv_counts, m_recv_displs;
  std::vector<long long> m_send_index, m_recv_index;  ///< rank by rank
  std::vector<double> m_send, m_received;
};

/// Ends every rank with `code` when more than one runs (an error that one rank meets alone
/// would leave the others waiting in a collective operation); returns otherwise.
void abort_if_distributed(int code);

}  // namespace peristat::parallel
