#include "parallel/thread_ranks.hpp"

#include <cstring>
#include <exception>
#include <mutex>
#include <thread>

#include <omp.h>

namespace peristat {

ThreadNet::ThreadNet(int ranks) : m_ranks(ranks), m_barrier(ranks), m_slots(static_cast<std::size_t>(ranks)) {}

void ThreadNet::run(const std::function<void(const ThreadRanks& ranks)>& body) {
  std::exception_ptr first;
  std::mutex guard;
  std::vector<std::thread> threads;
  for (int r = 0; r < m_ranks; ++r)
    threads.emplace_back([&, r] {
      omp_set_num_threads(1);
      const ThreadRanks ranks(*this, r);
      try {
        body(ranks);
      } catch (...) {
        {
          const std::lock_guard<std::mutex> lock(guard);
          if (!first) first = std::current_exception();
        }
        m_barrier.arrive_and_drop();
      }
    });
  for (std::thread& t : threads) t.join();
  if (first) std::rethrow_exception(first);
}

template <class Read>
void ThreadRanks::meet(const ThreadNet::Slot& mine, Read&& read) const {
  m_net.m_slots[static_cast<std::size_t>(m_rank)] = mine;
  m_net.m_barrier.arrive_and_wait();
  read(m_net.m_slots);
  m_net.m_barrier.arrive_and_wait();
}

namespace {
void copy(void* to, const void* from, std::int64_t n, std::size_t bytes) {
  if (n > 0) std::memcpy(to, from, static_cast<std::size_t>(n) * bytes);
}
}  // namespace

std::vector<std::int64_t> ThreadRanks::all_gather_counts(std::int64_t mine) const {
  std::vector<std::int64_t> counts(static_cast<std::size_t>(size()));
  meet({nullptr, mine, {}}, [&](const std::vector<ThreadNet::Slot>& slots) {
    for (std::size_t p = 0; p < slots.size(); ++p) counts[p] = slots[p].n;
  });
  return counts;
}

void ThreadRanks::all_gather_v(const void* mine, std::int64_t n, void* all, std::span<const std::int64_t>,
                               std::size_t bytes) const {
  meet({mine, n, {}}, [&](const std::vector<ThreadNet::Slot>& slots) {
    auto* out = static_cast<char*>(all);
    for (const ThreadNet::Slot& s : slots) {
      copy(out, s.data, s.n, bytes);
      out += static_cast<std::size_t>(s.n) * bytes;
    }
  });
}

void ThreadRanks::gather_v(const void* mine, std::int64_t n, void* all, std::span<const std::int64_t> counts,
                           std::size_t bytes) const {
  if (m_rank == 0)
    all_gather_v(mine, n, all, counts, bytes);
  else
    meet({mine, n, {}}, [](const std::vector<ThreadNet::Slot>&) {});
}

void ThreadRanks::broadcast_raw(void* data, std::int64_t n, std::size_t bytes) const {
  meet({data, n, {}}, [&](const std::vector<ThreadNet::Slot>& slots) {
    if (m_rank != 0) copy(data, slots[0].data, n, bytes);
  });
}

void ThreadRanks::all_to_all_v(const void* send, std::span<const std::int64_t> send_counts, void* recv,
                               std::span<const std::int64_t>, std::size_t bytes) const {
  meet({send, 0, send_counts}, [&](const std::vector<ThreadNet::Slot>& slots) {
    auto* out = static_cast<char*>(recv);
    for (const ThreadNet::Slot& s : slots) {
      // Rank p's elements for this rank follow its elements for the ranks before this one.
      std::int64_t offset = 0;
      for (int q = 0; q < m_rank; ++q) offset += s.counts[static_cast<std::size_t>(q)];
      const std::int64_t n = s.counts[static_cast<std::size_t>(m_rank)];
      copy(out, static_cast<const char*>(s.data) + static_cast<std::size_t>(offset) * bytes, n, bytes);
      out += static_cast<std::size_t>(n) * bytes;
    }
  });
}

}  // namespace peristat
