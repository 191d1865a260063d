#include "solvers/trilinos/parallel.hpp"

#include <algorithm>
#include <array>
#include <cstdlib>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include <Tpetra_Core.hpp>
#include <mpi.h>

#include "parallel/mpi/session.hpp"

namespace peristat::parallel {

namespace {

int g_argc = 0;  // Kokkos sees no arguments (ensure_started)
char** g_argv = nullptr;

void finalize_tpetra() {
  if (Tpetra::isInitialized()) Tpetra::finalize();
}

}  // namespace

void ensure_started() {
  if (Tpetra::isInitialized()) return;
  // MPI first (src/parallel/mpi), then Tpetra on it; Tpetra ends before MPI does. Kokkos sees
  // no arguments: Kokkos::initialize parses the command line and aborts on peristat's own
  // `--threads 1` (it wants its `--threads=N`), or prints its help for `--help`.
  start_mpi();
  Tpetra::initialize(&g_argc, &g_argv);
  before_mpi_ends(finalize_tpetra);
}

int rank() {
  if (!started()) return 0;
  int r = 0;
  MPI_Comm_rank(MPI_COMM_WORLD, &r);
  return r;
}

int size() {
  if (!started()) return 1;
  int n = 1;
  MPI_Comm_size(MPI_COMM_WORLD, &n);
  return n;
}

double max_over_ranks(double value) {
  if (size() <= 1) return value;
  double result = value;
  MPI_Allreduce(&value, &result, 1, MPI_DOUBLE, MPI_MAX, MPI_COMM_WORLD);
  return result;
}

long long sum_over_ranks(long long value) {
  if (size() <= 1) return value;
  long long result = value;
  MPI_Allreduce(&value, &result, 1, MPI_LONG_LONG, MPI_SUM, MPI_COMM_WORLD);
  return result;
}

void sum_in_rank_order(double* values, int n) {
  const int ranks = size();
  if (ranks <= 1 || n <= 0) return;
  // A few numbers per call, every ADR iteration: on the stack unless they are many.
  const std::size_t total = static_cast<std::size_t>(n) * static_cast<std::size_t>(ranks);
  std::array<double, 512> small;
  std::vector<double> large(total > small.size() ? total : 0);
  double* all = total > small.size() ? large.data() : small.data();
  MPI_Allgather(values, n, MPI_DOUBLE, all, n, MPI_DOUBLE, MPI_COMM_WORLD);
  for (int k = 0; k < n; ++k) {
    double s = 0.0;
    for (int p = 0; p < ranks; ++p) s += all[static_cast<std::size_t>(p) * static_cast<std::size_t>(n) + k];
    values[k] = s;
  }
}

double sum_over_ranks(double value) {
  sum_in_rank_order(&value, 1);
  return value;
}

std::vector<double> gather_over_ranks(const std::vector<double>& mine) {
  const int ranks = size();
  if (ranks <= 1) return mine;
  if (mine.size() > static_cast<std::size_t>(std::numeric_limits<int>::max()))
    throw std::length_error("gather_over_ranks: more than 2^31 values from one rank");
  const int count = static_cast<int>(mine.size());
  std::vector<int> counts(static_cast<std::size_t>(ranks)), displs(static_cast<std::size_t>(ranks), 0);
  MPI_Allgather(&count, 1, MPI_INT, counts.data(), 1, MPI_INT, MPI_COMM_WORLD);
  long long total = counts[0];
  for (std::size_t p = 1; p < counts.size(); ++p) {
    displs[p] = displs[p - 1] + counts[p - 1];
    total += counts[p];
    if (total > std::numeric_limits<int>::max())
      throw std::length_error("gather_over_ranks: more than 2^31 values over the ranks");
  }
  std::vector<double> all(static_cast<std::size_t>(total));
  MPI_Allgatherv(mine.data(), count, MPI_DOUBLE, all.data(), counts.data(), displs.data(), MPI_DOUBLE,
                 MPI_COMM_WORLD);
  return all;
}

OwnedExchange::OwnedExchange(const std::vector<int>& owner, bool keep_unowned) : m_rank(rank()) {
  const int ranks = size();
  m_counts.assign(static_cast<std::size_t>(ranks), 0);
  std::size_t owned = 0;
  for (const int p : owner) {
    if (p < 0 && keep_unowned) continue;
    if (p < 0 || p >= ranks) throw std::invalid_argument("OwnedExchange: an entry without an owner rank");
    ++m_counts[static_cast<std::size_t>(p)];
    ++owned;
  }
  m_displs.assign(static_cast<std::size_t>(ranks), 0);
  for (int p = 1; p < ranks; ++p)
    m_displs[static_cast<std::size_t>(p)] =
        m_displs[static_cast<std::size_t>(p - 1)] + m_counts[static_cast<std::size_t>(p - 1)];
  m_order.resize(owned);
  std::vector<int> next = m_displs;
  for (std::size_t k = 0; k < owner.size(); ++k)
    if (owner[k] >= 0)
      m_order[static_cast<std::size_t>(next[static_cast<std::size_t>(owner[k])]++)] =
          static_cast<long long>(k);
  m_send.resize(static_cast<std::size_t>(m_counts[static_cast<std::size_t>(m_rank)]));
  m_received.resize(owned);
}

void OwnedExchange::share(double* x) {
  if (m_counts.size() <= 1) return;
  const std::size_t first = static_cast<std::size_t>(m_displs[static_cast<std::size_t>(m_rank)]);
  for (std::size_t k = 0; k < m_send.size(); ++k) m_send[k] = x[m_order[first + k]];
  MPI_Allgatherv(m_send.data(), static_cast<int>(m_send.size()), MPI_DOUBLE, m_received.data(),
                 m_counts.data(), m_displs.data(), MPI_DOUBLE, MPI_COMM_WORLD);
  for (std::size_t k = 0; k < m_order.size(); ++k) x[m_order[k]] = m_received[k];
}

std::vector<long long> Halo::ask_owners(const std::vector<long long>& asked) {
  const auto R = static_cast<std::size_t>(size());
  m_recv_displs.assign(R, 0);
  if (R <= 1) {  // one process (MPI perhaps not started): nothing to ask, nothing to share
    m_send_counts.assign(R, 0);
    m_send_displs.assign(R, 0);
    return {};
  }
  for (std::size_t p = 1; p < R; ++p) m_recv_displs[p] = m_recv_displs[p - 1] + m_recv_counts[p - 1];
  m_send_counts.assign(R, 0);
  MPI_Alltoall(m_recv_counts.data(), 1, MPI_INT, m_send_counts.data(), 1, MPI_INT, MPI_COMM_WORLD);
  m_send_displs.assign(R, 0);
  for (std::size_t p = 1; p < R; ++p) m_send_displs[p] = m_send_displs[p - 1] + m_send_counts[p - 1];
  std::vector<long long> wanted(static_cast<std::size_t>(m_send_displs[R - 1] + m_send_counts[R - 1]));
  MPI_Alltoallv(asked.data(), m_recv_counts.data(), m_recv_displs.data(), MPI_LONG_LONG, wanted.data(),
                m_send_counts.data(), m_send_displs.data(), MPI_LONG_LONG, MPI_COMM_WORLD);
  m_send.resize(wanted.size());
  m_received.resize(asked.size());
  return wanted;
}

void Halo::share(double* x) {
  if (m_send_counts.size() <= 1) return;
  for (std::size_t k = 0; k < m_send.size(); ++k) m_send[k] = x[m_send_index[k]];
  MPI_Alltoallv(m_send.data(), m_send_counts.data(), m_send_displs.data(), MPI_DOUBLE, m_received.data(),
                m_recv_counts.data(), m_recv_displs.data(), MPI_DOUBLE, MPI_COMM_WORLD);
  for (std::size_t k = 0; k < m_received.size(); ++k) x[m_recv_index[k]] = m_received[k];
}

namespace {
/// Sorts the entries a rank receives by owner rank (stable: their order within an owner):
/// sets `counts` (per owner) and returns the order.
std::vector<std::size_t> by_owner(const std::vector<int>& entry_owner, int ranks, std::vector<int>& counts) {
  counts.assign(static_cast<std::size_t>(ranks), 0);
  for (const int p : entry_owner) ++counts[static_cast<std::size_t>(p)];
  std::vector<int> next(counts.size(), 0);
  for (std::size_t p = 1; p < counts.size(); ++p) next[p] = next[p - 1] + counts[p - 1];
  std::vector<std::size_t> slot(entry_owner.size());
  for (std::size_t k = 0; k < entry_owner.size(); ++k)
    slot[k] = static_cast<std::size_t>(next[static_cast<std::size_t>(entry_owner[k])]++);
  return slot;
}
}  // namespace

GhostExchange::GhostExchange(const std::vector<int>& owner, const std::vector<long long>& reads) {
  const int ranks = size(), me = rank();
  // What this rank receives: its reads that others own, grouped by owner (ascending within).
  std::vector<long long> ghosts;
  std::vector<int> ghost_owner;
  for (const long long k : reads) {
    const int p = owner.at(static_cast<std::size_t>(k));
    if (p < 0 || p >= ranks) throw std::invalid_argument("GhostExchange: a read entry without an owner rank");
    if (p == me) continue;
    ghosts.push_back(k);
    ghost_owner.push_back(p);
  }
  const std::vector<std::size_t> slot = by_owner(ghost_owner, ranks, m_recv_counts);
  m_recv_index.resize(ghosts.size());
  std::vector<long long> asked(ghosts.size());
  for (std::size_t g = 0; g < ghosts.size(); ++g) {
    m_recv_index[slot[g]] = static_cast<std::size_t>(ghosts[g]);
    asked[slot[g]] = ghosts[g];
  }
  // What it sends: each owner learns which of its entries every rank reads.
  const std::vector<long long> wanted = ask_owners(asked);
  m_send_index.resize(wanted.size());
  for (std::size_t k = 0; k < wanted.size(); ++k) {
    if (owner.at(static_cast<std::size_t>(wanted[k])) != me)
      throw std::logic_error("GhostExchange: a rank asked for an entry this rank does not own");
    m_send_index[k] = static_cast<std::size_t>(wanted[k]);
  }
}

PartExchange::PartExchange(const std::vector<std::int64_t>& ids, const std::vector<int>& owner,
                           std::size_t n_owned) {
  const int ranks = size(), me = rank();
  if (ids.size() != owner.size() || n_owned > ids.size())
    throw std::invalid_argument("PartExchange: one id and one owner per entry, the owned ones first");
  const std::vector<int> ghost_owner(owner.begin() + static_cast<std::ptrdiff_t>(n_owned), owner.end());
  for (const int p : ghost_owner)
    if (p < 0 || p >= ranks || p == me)
      throw std::invalid_argument("PartExchange: a ghost without another owner rank");
  // What this rank receives: its ghosts, grouped by owner (in their order within an owner).
  const std::vector<std::size_t> slot = by_owner(ghost_owner, ranks, m_recv_counts);
  m_recv_index.resize(ghost_owner.size());
  std::vector<long long> asked(ghost_owner.size());
  for (std::size_t g = 0; g < ghost_owner.size(); ++g) {
    m_recv_index[slot[g]] = n_owned + g;
    asked[slot[g]] = static_cast<long long>(ids[n_owned + g]);
  }
  // What it sends: each owner finds the ids asked of it among its own, which ascend.
  const std::vector<long long> wanted = ask_owners(asked);
  const auto first = ids.begin(), last = ids.begin() + static_cast<std::ptrdiff_t>(n_owned);
  if (!std::is_sorted(first, last)) throw std::invalid_argument("PartExchange: the owned ids must ascend");
  m_send_index.resize(wanted.size());
  for (std::size_t k = 0; k < wanted.size(); ++k) {
    const auto it = std::lower_bound(first, last, static_cast<std::int64_t>(wanted[k]));
    if (it == last || *it != wanted[k])
      throw std::logic_error("PartExchange: a rank asked for an id this rank does not own");
    m_send_index[k] = static_cast<std::size_t>(it - first);
  }
}

std::int64_t sum_over_lower_ranks(std::int64_t value, std::int64_t* total) {
  long long mine = value, lower = 0, all = value;
  if (size() > 1) {
    MPI_Exscan(&mine, &lower, 1, MPI_LONG_LONG, MPI_SUM, MPI_COMM_WORLD);
    if (rank() == 0) lower = 0;  // MPI_Exscan leaves rank 0's result undefined
    MPI_Allreduce(&mine, &all, 1, MPI_LONG_LONG, MPI_SUM, MPI_COMM_WORLD);
  }
  if (total) *total = all;
  return lower;
}

std::vector<double> gather_rows_on_root(const std::vector<std::int64_t>& ids,
                                        const std::vector<double>& values, int width, std::int64_t n_rows) {
  const auto w = static_cast<std::size_t>(width);
  if (width < 1 || values.size() != w * ids.size())
    throw std::invalid_argument("gather_rows_on_root: `width` values per id");
  const int ranks = size(), me = rank();
  const bool root = me == 0;
  std::vector<std::int64_t> all_ids;
  std::vector<double> all_values;
  if (ranks <= 1) {
    all_ids = ids;
    all_values = values;
  } else {
    if (values.size() > static_cast<std::size_t>(std::numeric_limits<int>::max()))
      throw std::length_error("gather_rows_on_root: more than 2^31 values from one rank");
    const int count = static_cast<int>(ids.size());
    std::vector<int> counts(root ? static_cast<std::size_t>(ranks) : 0);
    MPI_Gather(&count, 1, MPI_INT, counts.data(), 1, MPI_INT, 0, MPI_COMM_WORLD);
    std::vector<int> displs(counts.size(), 0), value_counts(counts.size()), value_displs(counts.size(), 0);
    if (root) {
      long long total = 0;
      for (std::size_t p = 0; p < counts.size(); ++p) {
        displs[p] = static_cast<int>(total);
        total += counts[p];
        if (total * width > std::numeric_limits<int>::max())
          throw std::length_error("gather_rows_on_root: more than 2^31 values over the ranks");
        value_counts[p] = counts[p] * width;
        value_displs[p] = displs[p] * width;
      }
      all_ids.resize(static_cast<std::size_t>(total));
      all_values.resize(static_cast<std::size_t>(total) * w);
    }
    static_assert(sizeof(long long) == sizeof(std::int64_t));
    MPI_Gatherv(ids.data(), count, MPI_LONG_LONG, all_ids.data(), counts.data(), displs.data(), MPI_LONG_LONG,
                0, MPI_COMM_WORLD);
    MPI_Gatherv(values.data(), count * width, MPI_DOUBLE, all_values.data(), value_counts.data(),
                value_displs.data(), MPI_DOUBLE, 0, MPI_COMM_WORLD);
  }
  if (!root) return {};
  std::vector<double> table(static_cast<std::size_t>(n_rows) * w);
  std::vector<char> seen(static_cast<std::size_t>(n_rows), 0);
  for (std::size_t k = 0; k < all_ids.size(); ++k) {
    const std::int64_t id = all_ids[k];
    if (id < 0 || id >= n_rows || seen[static_cast<std::size_t>(id)]++)
      throw std::logic_error("gather_rows_on_root: row " + std::to_string(id) +
                             " given twice or out of range");
    std::copy_n(all_values.begin() + static_cast<std::ptrdiff_t>(k * w), w,
                table.begin() + static_cast<std::ptrdiff_t>(static_cast<std::size_t>(id) * w));
  }
  if (all_ids.size() != static_cast<std::size_t>(n_rows))
    throw std::logic_error(
        "gather_rows_on_root: " + std::to_string(n_rows - static_cast<std::int64_t>(all_ids.size())) +
        " rows given by no rank");
  return table;
}

std::vector<double> rows_of(const std::vector<double>& table, int width,
                            const std::vector<std::int64_t>& ids) {
  const auto w = static_cast<std::size_t>(width);
  std::vector<double> out(ids.size() * w);
  for (std::size_t k = 0; k < ids.size(); ++k) {
    const auto id = static_cast<std::size_t>(ids[k]);
    if (ids[k] < 0 || (id + 1) * w > table.size()) throw std::out_of_range("rows_of: an id past the table");
    std::copy_n(table.begin() + static_cast<std::ptrdiff_t>(id * w), w,
                out.begin() + static_cast<std::ptrdiff_t>(k * w));
  }
  return out;
}

}  // namespace peristat::parallel
