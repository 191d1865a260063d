// The ranks of a run: the one object through which a component reaches another rank
// (docs/guide/architecture.md, "Distribution"). One process is one rank (SerialRanks); a run
// under mpirun has one MpiRanks per process (src/parallel/mpi); unit tests emulate P ranks by
// P threads of one process (ThreadRanks). Physics rooms take a `const Ranks&` and call it at
// named points; they never ask how the run is distributed.
//
// Every operation here is collective: every rank calls it at the same point, with the same
// element type. Reductions combine the ranks' values in rank order on every rank, so that
// every rank gets the same bits whatever the implementation (an MPI_Allreduce need not), and
// a run on P emulated ranks takes the decisions of a run on P MPI ranks.
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <span>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

namespace peristat {

class Ranks {
 public:
  virtual ~Ranks() = default;
  virtual int rank() const = 0;
  virtual int size() const = 0;
  bool root() const { return rank() == 0; }
  bool alone() const { return size() == 1; }

  // ---- Reductions, in rank order (one all-gather of a value per rank).
  double sum(double value) const { return sum_of(all_gather_one(value)); }
  std::int64_t sum(std::int64_t value) const { return sum_of(all_gather_one(value)); }
  double max(double value) const { return max_of(all_gather_one(value)); }
  std::int64_t max(std::int64_t value) const { return max_of(all_gather_one(value)); }
  /// True on every rank when `value` is true on any.
  bool any(bool value) const { return max(static_cast<std::int64_t>(value)) != 0; }
  /// Sums values[k] over the ranks in place, adding the ranks' values in rank order.
  void sum_in_rank_order(std::span<double> values) const;
  /// The sum of `value` over the ranks before this one (0 on rank 0), and over all ranks in
  /// `total`: the first global number of this rank's items when each rank numbers its own in turn.
  std::int64_t sum_over_lower_ranks(std::int64_t value, std::int64_t* total = nullptr) const;

  // ---- Gathers and broadcast of trivially copyable elements.
  /// Every rank's `mine` concatenated in rank order, on every rank; `counts` (if given) gets
  /// each rank's count.
  template <class T>
  std::vector<T> all_gather(std::span<const T> mine, std::vector<std::int64_t>* counts = nullptr) const;
  template <class T>
  std::vector<T> all_gather(const std::vector<T>& mine, std::vector<std::int64_t>* counts = nullptr) const {
    return all_gather(std::span<const T>(mine), counts);
  }
  /// Rank 0 gets every rank's `mine` in rank order (and `counts`); the others an empty vector.
  template <class T>
  std::vector<T> gather_to_root(std::span<const T> mine, std::vector<std::int64_t>* counts = nullptr) const;
  template <class T>
  std::vector<T> gather_to_root(const std::vector<T>& mine, std::vector<std::int64_t>* counts = nullptr) const {
    return gather_to_root(std::span<const T>(mine), counts);
  }
  /// Rank 0's `values` on every rank (sizes included).
  template <class T>
  void broadcast(std::vector<T>& values) const;
  /// Rank 0 receives every rank's rows of a table spread over the ranks by global id: each
  /// rank gives the ids of its rows and `width` values per row, row by row; rank 0 returns the
  /// n_rows x width table (row-major) with each row at its id, the other ranks an empty
  /// vector. Throws std::logic_error on rank 0 when the ids do not cover [0, n_rows) once each.
  template <class T>
  std::vector<T> gather_rows_on_root(std::span<const std::int64_t> ids, std::span<const T> values, int width,
                                     std::int64_t n_rows) const;

  // ---- The primitives every implementation provides (elements of `bytes` bytes each).
  /// Each rank's count, on every rank.
  virtual std::vector<std::int64_t> all_gather_counts(std::int64_t mine) const = 0;
  /// `all` (sum of counts elements) gets every rank's elements in rank order.
  virtual void all_gather_v(const void* mine, std::int64_t n, void* all, std::span<const std::int64_t> counts,
                            std::size_t bytes) const = 0;
  /// Rank 0's `all` gets every rank's elements in rank order (counts known on rank 0 only).
  virtual void gather_v(const void* mine, std::int64_t n, void* all, std::span<const std::int64_t> counts,
                        std::size_t bytes) const = 0;
  virtual void broadcast_raw(void* data, std::int64_t n, std::size_t bytes) const = 0;
  /// Each rank sends send_counts[q] elements to rank q (consecutive in `send`, rank by rank)
  /// and receives recv_counts[p] from rank p (consecutive in `recv`, rank by rank).
  virtual void all_to_all_v(const void* send, std::span<const std::int64_t> send_counts, void* recv,
                            std::span<const std::int64_t> recv_counts, std::size_t bytes) const = 0;
  /// recv_counts[p]: what rank p sends this rank, from every rank's send_counts.
  std::vector<std::int64_t> all_to_all_counts(std::span<const std::int64_t> send_counts) const;

 private:
  template <class T>
  std::vector<T> all_gather_one(T value) const {
    return all_gather(std::span<const T>(&value, 1));
  }
  template <class T>
  static T sum_of(const std::vector<T>& values) {
    T total = values.front();  // one rank: the value itself, bit for bit (a -0.0 stays)
    for (std::size_t p = 1; p < values.size(); ++p) total += values[p];
    return total;
  }
  template <class T>
  static T max_of(const std::vector<T>& values) {
    return *std::max_element(values.begin(), values.end());
  }
};

/// One process: one rank, every collective the identity.
class SerialRanks final : public Ranks {
 public:
  int rank() const override { return 0; }
  int size() const override { return 1; }
  std::vector<std::int64_t> all_gather_counts(std::int64_t mine) const override { return {mine}; }
  void all_gather_v(const void* mine, std::int64_t n, void* all, std::span<const std::int64_t>,
                    std::size_t bytes) const override;
  void gather_v(const void* mine, std::int64_t n, void* all, std::span<const std::int64_t>,
                std::size_t bytes) const override;
  void broadcast_raw(void*, std::int64_t, std::size_t) const override {}
  void all_to_all_v(const void* send, std::span<const std::int64_t> send_counts, void* recv,
                    std::span<const std::int64_t>, std::size_t bytes) const override;
};

/// The serial ranks every one-process component may share (stateless).
const Ranks& serial_ranks();

// ---- Templates.
template <class T>
std::vector<T> Ranks::all_gather(std::span<const T> mine, std::vector<std::int64_t>* counts) const {
  static_assert(std::is_trivially_copyable_v<T>);
  std::vector<std::int64_t> n = all_gather_counts(static_cast<std::int64_t>(mine.size()));
  std::int64_t total = 0;
  for (const std::int64_t c : n) total += c;
  std::vector<T> all(static_cast<std::size_t>(total));
  all_gather_v(mine.data(), static_cast<std::int64_t>(mine.size()), all.data(), n, sizeof(T));
  if (counts) *counts = std::move(n);
  return all;
}

template <class T>
std::vector<T> Ranks::gather_to_root(std::span<const T> mine, std::vector<std::int64_t>* counts) const {
  static_assert(std::is_trivially_copyable_v<T>);
  // Every rank learns the counts (P numbers): simpler than a rooted gather of them.
  std::vector<std::int64_t> n = all_gather_counts(static_cast<std::int64_t>(mine.size()));
  std::int64_t total = 0;
  for (const std::int64_t c : n) total += c;
  std::vector<T> all(root() ? static_cast<std::size_t>(total) : 0);
  gather_v(mine.data(), static_cast<std::int64_t>(mine.size()), all.data(), n, sizeof(T));
  if (counts) *counts = root() ? std::move(n) : std::vector<std::int64_t>();
  return all;
}

template <class T>
void Ranks::broadcast(std::vector<T>& values) const {
  static_assert(std::is_trivially_copyable_v<T>);
  std::int64_t n = static_cast<std::int64_t>(values.size());
  broadcast_raw(&n, 1, sizeof n);
  values.resize(static_cast<std::size_t>(n));
  broadcast_raw(values.data(), n, sizeof(T));
}

template <class T>
std::vector<T> Ranks::gather_rows_on_root(std::span<const std::int64_t> ids, std::span<const T> values, int width,
                                          std::int64_t n_rows) const {
  const auto w = static_cast<std::size_t>(width);
  if (width < 1 || values.size() != w * ids.size())
    throw std::invalid_argument("gather_rows_on_root: `width` values per id");
  const std::vector<std::int64_t> all_ids = gather_to_root(ids);
  const std::vector<T> all_values = gather_to_root(values);
  if (!root()) return {};
  std::vector<T> table(static_cast<std::size_t>(n_rows) * w);
  std::vector<char> seen(static_cast<std::size_t>(n_rows), 0);
  for (std::size_t k = 0; k < all_ids.size(); ++k) {
    const std::int64_t id = all_ids[k];
    if (id < 0 || id >= n_rows || seen[static_cast<std::size_t>(id)]++)
      throw std::logic_error("gather_rows_on_root: row " + std::to_string(id) + " given twice or out of range");
    std::copy_n(all_values.begin() + static_cast<std::ptrdiff_t>(k * w), w,
                table.begin() + static_cast<std::ptrdiff_t>(static_cast<std::size_t>(id) * w));
  }
  if (all_ids.size() != static_cast<std::size_t>(n_rows))
    throw std::logic_error("gather_rows_on_root: " +
                           std::to_string(n_rows - static_cast<std::int64_t>(all_ids.size())) +
                           " rows given by no rank");
  return table;
}

/// The inverse for a table every rank holds alike (a checkpoint read on every rank): the rows
/// `ids` of `table` (n_rows x width, row-major), row by row. No communication.
template <class T>
std::vector<T> rows_of(std::span<const T> table, int width, std::span<const std::int64_t> ids) {
  const auto w = static_cast<std::size_t>(width);
  std::vector<T> out(ids.size() * w);
  for (std::size_t k = 0; k < ids.size(); ++k) {
    const auto id = static_cast<std::size_t>(ids[k]);
    if (ids[k] < 0 || (id + 1) * w > table.size()) throw std::out_of_range("rows_of: an id past the table");
    std::copy_n(table.begin() + static_cast<std::ptrdiff_t>(id * w), w,
                out.begin() + static_cast<std::ptrdiff_t>(k * w));
  }
  return out;
}

}  // namespace peristat
