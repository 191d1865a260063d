#include "parallel/exchange.hpp"

#include <algorithm>
#include <stdexcept>

namespace peristat {

namespace {

template <class T>
std::size_t bytes_of(const std::vector<T>& v) {
  return v.capacity() * sizeof(T);
}

/// Sorts the entries a rank receives by owner rank (stable: their order within an owner):
/// sets `counts` (per owner) and returns the order.
std::vector<std::size_t> by_owner(const std::vector<int>& entry_owner, int ranks, std::vector<std::int64_t>& counts) {
  counts.assign(static_cast<std::size_t>(ranks), 0);
  for (const int p : entry_owner) ++counts[static_cast<std::size_t>(p)];
  std::vector<std::int64_t> next(counts.size(), 0);
  for (std::size_t p = 1; p < counts.size(); ++p) next[p] = next[p - 1] + counts[p - 1];
  std::vector<std::size_t> slot(entry_owner.size());
  for (std::size_t k = 0; k < entry_owner.size(); ++k)
    slot[k] = static_cast<std::size_t>(next[static_cast<std::size_t>(entry_owner[k])]++);
  return slot;
}

}  // namespace

std::vector<std::int64_t> Halo::ask_owners(const std::vector<std::int64_t>& asked) {
  m_send_counts = m_ranks->all_to_all_counts(m_recv_counts);
  std::int64_t wanted_total = 0;
  for (const std::int64_t c : m_send_counts) wanted_total += c;
  std::vector<std::int64_t> wanted(static_cast<std::size_t>(wanted_total));
  m_ranks->all_to_all_v(asked.data(), m_recv_counts, wanted.data(), m_send_counts, sizeof(std::int64_t));
  m_send.resize(wanted.size());  // the doubles' buffers now, the integers' at their first share()
  m_received.resize(asked.size());
  return wanted;
}

template <class T>
void Halo::share_as(T* x, std::vector<T>& send, std::vector<T>& received) {
  if (m_ranks->alone()) return;
  send.resize(m_send_index.size());
  received.resize(m_recv_index.size());
  for (std::size_t k = 0; k < send.size(); ++k) send[k] = x[m_send_index[k]];
  m_ranks->all_to_all_v(send.data(), m_send_counts, received.data(), m_recv_counts, sizeof(T));
  for (std::size_t k = 0; k < received.size(); ++k) x[m_recv_index[k]] = received[k];
}

std::size_t Halo::memory_bytes() const {
  return bytes_of(m_send_counts) + bytes_of(m_recv_counts) + bytes_of(m_send_index) + bytes_of(m_recv_index) +
         bytes_of(m_send) + bytes_of(m_received) + bytes_of(m_send_ids) + bytes_of(m_received_ids);
}

PartExchange::PartExchange(const Ranks& ranks, const std::vector<std::int64_t>& ids, const std::vector<int>& owner,
                           std::size_t n_owned)
    : Halo(ranks) {
  const int size = ranks.size(), me = ranks.rank();
  if (ids.size() != owner.size() || n_owned > ids.size())
    throw std::invalid_argument("PartExchange: one id and one owner per entry, the owned ones first");
  const std::vector<int> ghost_owner(owner.begin() + static_cast<std::ptrdiff_t>(n_owned), owner.end());
  for (const int p : ghost_owner)
    if (p < 0 || p >= size || p == me) throw std::invalid_argument("PartExchange: a ghost without another owner rank");
  // What this rank receives: its ghosts, grouped by owner (in their order within an owner).
  const std::vector<std::size_t> slot = by_owner(ghost_owner, size, m_recv_counts);
  m_recv_index.resize(ghost_owner.size());
  std::vector<std::int64_t> asked(ghost_owner.size());
  for (std::size_t g = 0; g < ghost_owner.size(); ++g) {
    m_recv_index[slot[g]] = n_owned + g;
    asked[slot[g]] = ids[n_owned + g];
  }
  // What it sends: each owner finds the ids asked of it among its own, which ascend.
  const std::vector<std::int64_t> wanted = ask_owners(asked);
  const auto first = ids.begin(), last = ids.begin() + static_cast<std::ptrdiff_t>(n_owned);
  if (!std::is_sorted(first, last)) throw std::invalid_argument("PartExchange: the owned ids must ascend");
  m_send_index.resize(wanted.size());
  for (std::size_t k = 0; k < wanted.size(); ++k) {
    const auto it = std::lower_bound(first, last, wanted[k]);
    if (it == last || *it != wanted[k])
      throw std::logic_error("PartExchange: a rank asked for an id this rank does not own");
    m_send_index[k] = static_cast<std::size_t>(it - first);
  }
}

OwnedEntriesExchange::OwnedEntriesExchange(const Ranks& ranks, const std::vector<std::int64_t>& ids,
                                           const std::vector<int>& owner, std::size_t n_owned) {
  std::vector<std::int64_t> entry_ids;
  std::vector<int> entry_owner;
  for (std::size_t p = 0; p < owner.size(); ++p)
    if (owner[p] >= 0) {
      m_entries.push_back(p);
      entry_ids.push_back(ids[p]);
      entry_owner.push_back(owner[p]);
    }
  m_scratch.resize(m_entries.size());  // the doubles' scratch now, the integers' at its first share()
  m_exchange = std::make_unique<PartExchange>(ranks, entry_ids, entry_owner, n_owned);
}

template <class T>
void OwnedEntriesExchange::share_as(T* x, std::vector<T>& scratch) {
  scratch.resize(m_entries.size());
  for (std::size_t k = 0; k < m_entries.size(); ++k) scratch[k] = x[m_entries[k]];
  m_exchange->share(scratch.data());
  for (std::size_t k = 0; k < m_entries.size(); ++k) x[m_entries[k]] = scratch[k];
}

std::size_t OwnedEntriesExchange::memory_bytes() const {
  return bytes_of(m_entries) + bytes_of(m_scratch) + bytes_of(m_scratch_ids) + m_exchange->memory_bytes();
}

// The element types the headers' share() overloads use.
template void Halo::share_as(double*, std::vector<double>&, std::vector<double>&);
template void Halo::share_as(std::int64_t*, std::vector<std::int64_t>&, std::vector<std::int64_t>&);
template void OwnedEntriesExchange::share_as(double*, std::vector<double>&);
template void OwnedEntriesExchange::share_as(std::int64_t*, std::vector<std::int64_t>&);

}  // namespace peristat
