#include "core/global_ids.hpp"

#include <algorithm>
#include <numeric>
#include <stdexcept>
#include <string>

namespace peristat {

GlobalIds::GlobalIds(Index n) : m_id(static_cast<std::size_t>(n)), m_n_whole(n) {
  std::iota(m_id.begin(), m_id.end(), std::int64_t{0});
}

GlobalIds::GlobalIds(std::vector<std::int64_t> ids, std::int64_t n_whole)
    : m_id(std::move(ids)), m_n_whole(n_whole), m_identity(false) {
  m_by_id.reserve(m_id.size());
  for (std::size_t q = 0; q < m_id.size(); ++q) {
    if (m_id[q] < 0 || m_id[q] >= n_whole)
      throw std::logic_error("GlobalIds: id " + std::to_string(m_id[q]) + " outside a model of " +
                             std::to_string(n_whole) + " particles");
    m_by_id.emplace_back(m_id[q], static_cast<Index>(q));
  }
  std::sort(m_by_id.begin(), m_by_id.end());
  for (std::size_t q = 1; q < m_by_id.size(); ++q)
    if (m_by_id[q].first == m_by_id[q - 1].first)
      throw std::logic_error("GlobalIds: id " + std::to_string(m_by_id[q].first) + " given twice");
}

Index GlobalIds::local_of(std::int64_t g) const {
  if (m_identity) return g >= 0 && g < m_n_whole ? static_cast<Index>(g) : -1;
  const auto it = std::lower_bound(m_by_id.begin(), m_by_id.end(), std::pair<std::int64_t, Index>(g, -1));
  return it != m_by_id.end() && it->first == g ? it->second : -1;
}

std::size_t GlobalIds::memory_bytes() const {
  return m_id.capacity() * sizeof(std::int64_t) + m_by_id.capacity() * sizeof(m_by_id[0]);
}

}  // namespace peristat
