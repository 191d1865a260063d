#include "parallel/ranks.hpp"

#include <array>
#include <cstring>

namespace peristat {

void Ranks::sum_in_rank_order(std::span<double> values) const {
  const int ranks = size();
  if (ranks <= 1 || values.empty()) return;
  // A few numbers per call, every ADR iteration: on the stack unless they are many.
  const std::size_t n = values.size(), total = n * static_cast<std::size_t>(ranks);
  std::array<double, 512> small;
  std::vector<double> large(total > small.size() ? total : 0);
  double* all = total > small.size() ? large.data() : small.data();
  const std::vector<std::int64_t> counts(static_cast<std::size_t>(ranks), static_cast<std::int64_t>(n));
  all_gather_v(values.data(), static_cast<std::int64_t>(n), all, counts, sizeof(double));
  for (std::size_t k = 0; k < n; ++k) {
    double s = 0.0;
    for (std::size_t p = 0; p < static_cast<std::size_t>(ranks); ++p) s += all[p * n + k];
    values[k] = s;
  }
}

std::int64_t Ranks::sum_over_lower_ranks(std::int64_t value, std::int64_t* total) const {
  const std::vector<std::int64_t> all = all_gather(std::span<const std::int64_t>(&value, 1));
  std::int64_t lower = 0, sum = 0;
  for (std::size_t p = 0; p < all.size(); ++p) {
    if (static_cast<int>(p) < rank()) lower += all[p];
    sum += all[p];
  }
  if (total) *total = sum;
  return lower;
}

std::vector<std::int64_t> Ranks::all_to_all_counts(std::span<const std::int64_t> send_counts) const {
  const auto ranks = static_cast<std::size_t>(size());
  if (send_counts.size() != ranks) throw std::invalid_argument("all_to_all_counts: one count per rank");
  std::vector<std::int64_t> recv(ranks);
  const std::vector<std::int64_t> ones(ranks, 1);
  all_to_all_v(send_counts.data(), ones, recv.data(), ones, sizeof(std::int64_t));
  return recv;
}

void SerialRanks::all_gather_v(const void* mine, std::int64_t n, void* all, std::span<const std::int64_t>,
                               std::size_t bytes) const {
  if (n > 0) std::memcpy(all, mine, static_cast<std::size_t>(n) * bytes);
}

void SerialRanks::gather_v(const void* mine, std::int64_t n, void* all, std::span<const std::int64_t>,
                           std::size_t bytes) const {
  if (n > 0) std::memcpy(all, mine, static_cast<std::size_t>(n) * bytes);
}

void SerialRanks::all_to_all_v(const void* send, std::span<const std::int64_t> send_counts, void* recv,
                               std::span<const std::int64_t>, std::size_t bytes) const {
  if (send_counts[0] > 0) std::memcpy(recv, send, static_cast<std::size_t>(send_counts[0]) * bytes);
}

const Ranks& serial_ranks() {
  static const SerialRanks one;
  return one;
}

}  // namespace peristat
