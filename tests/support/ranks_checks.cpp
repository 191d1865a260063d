#include "support/ranks_checks.hpp"

#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include <gtest/gtest.h>

#include "parallel/exchange.hpp"

namespace peristat::test {

namespace {
/// Ids past 2^53, where a double no longer holds every integer: they must travel exactly.
constexpr std::int64_t big = (std::int64_t{1} << 60) + 1;
}  // namespace

void check_reductions(const Ranks& ranks) {
  const int r = ranks.rank(), P = ranks.size();
  // 1e16 on rank 0, then 1 on every other rank, then -1e16 on the last (P >= 2): in rank
  // order (1e16 + 1) rounds to 1e16 (spacing 2), and each later 1 rounds away again.
  double value = r == 0 ? 1e16 : 1.0;
  if (P >= 3 && r == P - 1) value = -1e16;
  double expected = 1e16;
  for (int p = 1; p < P; ++p) expected += (P >= 3 && p == P - 1) ? -1e16 : 1.0;
  EXPECT_EQ(ranks.sum(value), expected);  // bit for bit: the order of the additions is rank order
  std::vector<double> several = {value, 2.0 * r, -0.5};
  ranks.sum_in_rank_order(several);
  EXPECT_EQ(several[0], expected);
  EXPECT_EQ(several[1], static_cast<double>(P * (P - 1)));
  EXPECT_EQ(several[2], -0.5 * P);
  EXPECT_EQ(ranks.max(static_cast<double>(r) - 0.25), P - 1.25);
  EXPECT_EQ(ranks.sum(big + r), P * big + P * (P - 1) / 2);  // 64-bit integers stay exact
  EXPECT_EQ(ranks.max(big + r), big + P - 1);
  EXPECT_EQ(ranks.any(r == P - 1), true);
  EXPECT_EQ(ranks.any(false), false);
  std::int64_t total = -1;
  EXPECT_EQ(ranks.sum_over_lower_ranks(r + 1, &total), r * (r + 1) / 2);
  EXPECT_EQ(total, P * (P + 1) / 2);
}

void check_gathers(const Ranks& ranks) {
  const int r = ranks.rank(), P = ranks.size();
  // Rank r gives r ids: big + 10 r + k.
  std::vector<std::int64_t> mine;
  for (int k = 0; k < r; ++k) mine.push_back(big + 10 * r + k);
  std::vector<std::int64_t> counts;
  const std::vector<std::int64_t> all = ranks.all_gather(mine, &counts);
  std::vector<std::int64_t> expected;
  for (int p = 0; p < P; ++p)
    for (int k = 0; k < p; ++k) expected.push_back(big + 10 * p + k);
  EXPECT_EQ(all, expected);
  ASSERT_EQ(counts.size(), static_cast<std::size_t>(P));
  for (int p = 0; p < P; ++p) EXPECT_EQ(counts[static_cast<std::size_t>(p)], p);
  const std::vector<std::int64_t> at_root = ranks.gather_to_root(mine);
  EXPECT_EQ(at_root, r == 0 ? expected : std::vector<std::int64_t>());
  // Broadcast: rank 0's vector, its size included.
  std::vector<double> b = r == 0 ? std::vector<double>{0.1, -0.0, std::numeric_limits<double>::infinity()}
                                 : std::vector<double>{7.0};
  ranks.broadcast(b);
  ASSERT_EQ(b.size(), 3u);
  EXPECT_EQ(b[0], 0.1);
  EXPECT_TRUE(std::signbit(b[1]));
  EXPECT_TRUE(std::isinf(b[2]));
  // Rows by id: 3 P rows of width 2, rank p giving rows p, p + P, p + 2 P in reverse.
  std::vector<std::int64_t> ids;
  std::vector<double> values;
  for (int k = 2; k >= 0; --k) {
    const std::int64_t id = r + k * P;
    ids.push_back(id);
    values.push_back(static_cast<double>(id));
    values.push_back(-static_cast<double>(id) / 3.0);
  }
  const std::vector<double> table =
      ranks.gather_rows_on_root(std::span<const std::int64_t>(ids), std::span<const double>(values), 2, 3 * P);
  if (r == 0) {
    ASSERT_EQ(table.size(), static_cast<std::size_t>(6 * P));
    for (int id = 0; id < 3 * P; ++id) {
      EXPECT_EQ(table[static_cast<std::size_t>(2 * id)], id);
      EXPECT_EQ(table[static_cast<std::size_t>(2 * id + 1)], -id / 3.0);
    }
  } else {
    EXPECT_TRUE(table.empty());
  }
}

void check_exchanges(const Ranks& ranks) {
  const int r = ranks.rank(), P = ranks.size();
  // all_to_all_v: rank r sends q + 1 values r * 100 + q to rank q.
  std::vector<std::int64_t> send_counts, send;
  for (int q = 0; q < P; ++q) {
    send_counts.push_back(q + 1);
    for (int k = 0; k <= q; ++k) send.push_back(r * 100 + q);
  }
  const std::vector<std::int64_t> recv_counts = ranks.all_to_all_counts(send_counts);
  std::vector<std::int64_t> recv(static_cast<std::size_t>(P * (r + 1)));
  for (int p = 0; p < P; ++p) EXPECT_EQ(recv_counts[static_cast<std::size_t>(p)], r + 1);
  ranks.all_to_all_v(send.data(), send_counts, recv.data(), recv_counts, sizeof(std::int64_t));
  for (int p = 0; p < P; ++p)
    for (int k = 0; k <= r; ++k) EXPECT_EQ(recv[static_cast<std::size_t>(p * (r + 1) + k)], p * 100 + r);

  // A line of 10 P entries, rank p owning [10 p, 10 p + 10); a rank reads two entries on each
  // side of its range (its ghosts).
  const int n = 10 * P, first = 10 * r, last = first + 10;
  const auto value = [](std::int64_t id) { return 1.0 + 0.5 * static_cast<double>(id); };
  std::vector<int> owner(static_cast<std::size_t>(n));
  for (int k = 0; k < n; ++k) owner[static_cast<std::size_t>(k)] = k / 10;
  // PartExchange: the owned entries first (ascending ids), then the ghosts.
  std::vector<std::int64_t> ids;
  std::vector<int> part_owner;
  for (int k = first; k < last; ++k) ids.push_back(k), part_owner.push_back(r);
  for (const int k : {first - 2, first - 1, last, last + 1})
    if (k >= 0 && k < n) ids.push_back(k), part_owner.push_back(k / 10);
  std::vector<double> x(ids.size(), std::numeric_limits<double>::quiet_NaN());
  for (std::size_t l = 0; l < 10; ++l) x[l] = value(ids[l]);
  PartExchange part(ranks, ids, part_owner, 10);
  EXPECT_EQ(part.ghosts(), ids.size() - 10);
  EXPECT_GT(part.memory_bytes(), 0u);
  part.share(x.data());
  for (std::size_t l = 0; l < x.size(); ++l) EXPECT_EQ(x[l], value(ids[l])) << "entry " << l;
  // Integers past 2^53 travel exactly.
  std::vector<std::int64_t> big_ids(ids.size(), -1);
  for (std::size_t l = 0; l < 10; ++l) big_ids[l] = big + ids[l];
  part.share(big_ids.data());
  for (std::size_t l = 0; l < ids.size(); ++l) EXPECT_EQ(big_ids[l], big + ids[l]) << "entry " << l;
}

}  // namespace peristat::test
