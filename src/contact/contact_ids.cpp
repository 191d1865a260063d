#include "contact/contact_ids.hpp"

#include <stdexcept>

namespace peristat {

ContactIds::ContactIds(ContactRanks share, Index n, const Ranks& ranks) : m_share(std::move(share)), m_ranks(ranks) {
  if (!m_share.ids) {  // a whole model: one rank's, numbered by itself
    if (ranks.size() > 1)
      throw std::logic_error("ContactSystem: a model without global ids is one process's, not one of " +
                             std::to_string(ranks.size()) + " ranks'");
    m_own = GlobalIds(n);
    m_share.counted.assign(static_cast<std::size_t>(n), 1);
  }
  if (ids().size() != n || m_share.counted.size() != static_cast<std::size_t>(n))
    throw std::logic_error("ContactSystem: a part needs a global id and a counted flag per particle");
}

}  // namespace peristat
