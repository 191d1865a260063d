#include "contact/contact_ids.hpp"

#include <algorithm>
#include <numeric>
#include <stdexcept>

namespace peristat {

ContactIds::ContactIds(ContactRanks share, Index n, const Ranks& ranks)
    : m_share(std::move(share)), m_ranks(ranks), m_n(n) {
  if (m_share.global_id.empty()) {  // a whole model: one rank's, numbered by itself
    if (ranks.size() > 1)
      throw std::logic_error("ContactSystem: a model without global ids is one process's, not one of " +
                             std::to_string(ranks.size()) + " ranks'");
    m_share.global_id.resize(static_cast<std::size_t>(n));
    std::iota(m_share.global_id.begin(), m_share.global_id.end(), std::int64_t{0});
    m_share.counted.assign(static_cast<std::size_t>(n), 1);
    m_share.n_particles_whole = n;
  }
  if (m_share.global_id.size() != static_cast<std::size_t>(n) || m_share.counted.size() != m_share.global_id.size())
    throw std::logic_error("ContactSystem: a part needs a global id and a counted flag per particle");
  m_by_global.reserve(m_share.global_id.size());
  for (std::size_t q = 0; q < m_share.global_id.size(); ++q)
    m_by_global.emplace_back(m_share.global_id[q], static_cast<Index>(q));
  std::sort(m_by_global.begin(), m_by_global.end());
}

Index ContactIds::local_of(std::int64_t g) const {
  const auto it =
      std::lower_bound(m_by_global.begin(), m_by_global.end(), std::pair<std::int64_t, Index>(g, -1));
  return it != m_by_global.end() && it->first == g ? it->second : -1;
}

}  // namespace peristat
