#include "contact/contact_ids.hpp"

#include <algorithm>
#include <stdexcept>

namespace peristat {

ContactIds::ContactIds(ContactRanks share, Index n, const Ranks& ranks)
    : m_share(std::move(share)), m_ranks(ranks), m_n(n) {
  if (!partitioned()) return;
  if (m_share.global_id.size() != static_cast<std::size_t>(n) || m_share.counted.size() != m_share.global_id.size())
    throw std::logic_error("ContactSystem: a part needs a global id and a counted flag per particle");
  m_by_global.reserve(m_share.global_id.size());
  for (std::size_t q = 0; q < m_share.global_id.size(); ++q)
    m_by_global.emplace_back(m_share.global_id[q], static_cast<Index>(q));
  std::sort(m_by_global.begin(), m_by_global.end());
}

Index ContactIds::local_of(std::int64_t g) const {
  if (!partitioned()) return g >= 0 && g < m_n ? static_cast<Index>(g) : -1;
  const auto it =
      std::lower_bound(m_by_global.begin(), m_by_global.end(), std::pair<std::int64_t, Index>(g, -1));
  return it != m_by_global.end() && it->first == g ? it->second : -1;
}

std::vector<double> ContactIds::gather_on_root(const std::vector<std::int64_t>& ids, const std::vector<double>& values,
                                               int width, std::int64_t n_rows) const {
  if (partitioned())
    return m_ranks.gather_rows_on_root(std::span<const std::int64_t>(ids), std::span<const double>(values), width,
                                       n_rows);
  const auto w = static_cast<std::size_t>(width);
  std::vector<double> table(static_cast<std::size_t>(n_rows) * w);
  for (std::size_t k = 0; k < ids.size(); ++k)
    std::copy_n(values.begin() + static_cast<std::ptrdiff_t>(k * w), w,
                table.begin() + static_cast<std::ptrdiff_t>(static_cast<std::size_t>(ids[k]) * w));
  return table;
}

}  // namespace peristat
