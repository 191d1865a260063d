#include "contact/contact_ids.hpp"

#include <algorithm>
#include <stdexcept>

namespace peristat {

ContactIds::ContactIds(ContactRanks ranks, Index n) : m_ranks(std::move(ranks)), m_n(n) {
  if (!partitioned()) return;
  if (m_ranks.global_id.size() != static_cast<std::size_t>(n) || m_ranks.counted.size() != m_ranks.global_id.size() ||
      !m_ranks.gather || !m_ranks.gather_on_root)
    throw std::logic_error("ContactSystem: a part needs a global id and a counted flag per particle, and the gathers");
  m_by_global.reserve(m_ranks.global_id.size());
  for (std::size_t q = 0; q < m_ranks.global_id.size(); ++q)
    m_by_global.emplace_back(m_ranks.global_id[q], static_cast<Index>(q));
  std::sort(m_by_global.begin(), m_by_global.end());
}

Index ContactIds::local_of(std::int64_t g) const {
  if (!partitioned()) return g >= 0 && g < m_n ? static_cast<Index>(g) : -1;
  const auto it =
      std::lower_bound(m_by_global.begin(), m_by_global.end(), std::pair<std::int64_t, Index>(g, -1));
  return it != m_by_global.end() && it->first == g ? it->second : -1;
}

std::vector<double> ContactIds::gather(const std::vector<double>& mine) const {
  return partitioned() ? m_ranks.gather(mine) : mine;
}

double ContactIds::max_over_ranks(double value) const {
  if (!partitioned()) return value;
  double out = value;
  for (const double v : m_ranks.gather({value})) out = std::max(out, v);
  return out;
}

std::vector<double> ContactIds::gather_on_root(const std::vector<std::int64_t>& ids, const std::vector<double>& values,
                                               int width, std::int64_t n_rows) const {
  if (partitioned()) return m_ranks.gather_on_root(ids, values, width, n_rows);
  const auto w = static_cast<std::size_t>(width);
  std::vector<double> table(static_cast<std::size_t>(n_rows) * w);
  for (std::size_t k = 0; k < ids.size(); ++k)
    std::copy_n(values.begin() + static_cast<std::ptrdiff_t>(k * w), w,
                table.begin() + static_cast<std::ptrdiff_t>(static_cast<std::size_t>(ids[k]) * w));
  return table;
}

std::vector<std::size_t> ContactIds::rows_in_whole_order(const std::vector<double>& all, std::size_t width) const {
  std::vector<std::size_t> rows(all.size() / width);
  for (std::size_t r = 0; r < rows.size(); ++r) rows[r] = r * width;
  if (partitioned())
    std::sort(rows.begin(), rows.end(), [&](std::size_t a, std::size_t b) {
      return std::pair(all[a], all[a + 1]) < std::pair(all[b], all[b + 1]);
    });
  return rows;
}

}  // namespace peristat
