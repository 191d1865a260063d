#include "support/emulated_ranks.hpp"

#include <algorithm>
#include <exception>
#include <mutex>
#include <thread>

#include <omp.h>

namespace peristat::test {

std::vector<int> x_cut_owners(const Model& model, int ranks) {
  const Constraints& cons = model.constraints;
  std::vector<Index> nodes;
  for (Index p = 0; p < model.particles.size(); ++p)
    if (cons.free_index[2 * p] >= 0 || cons.free_index[2 * p + 1] >= 0) nodes.push_back(p);
  std::stable_sort(nodes.begin(), nodes.end(), [&](Index a, Index b) {
    return model.particles.position[a].x() < model.particles.position[b].x();
  });
  std::vector<int> owner(static_cast<std::size_t>(model.particles.size()), -1);
  for (std::size_t k = 0; k < nodes.size(); ++k)
    owner[static_cast<std::size_t>(nodes[k])] =
        static_cast<int>(k * static_cast<std::size_t>(ranks) / nodes.size());
  return owner;
}

EmulatedRanks::EmulatedRanks(int ranks)
    : m_ranks(ranks), m_barrier(ranks), m_slots(static_cast<std::size_t>(ranks)) {}

void EmulatedRanks::run(const std::function<void(int rank)>& body) {
  std::exception_ptr first;
  std::mutex guard;
  std::vector<std::thread> threads;
  for (int r = 0; r < m_ranks; ++r)
    threads.emplace_back([&, r] {
      omp_set_num_threads(1);
      try {
        body(r);
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

std::vector<double> EmulatedRanks::gather(int rank, const std::vector<double>& mine) {
  m_slots[static_cast<std::size_t>(rank)] = mine;
  m_barrier.arrive_and_wait();
  std::vector<double> all;
  for (const std::vector<double>& slot : m_slots) all.insert(all.end(), slot.begin(), slot.end());
  m_barrier.arrive_and_wait();  // nobody writes its slot again before every rank has read
  return all;
}

double EmulatedRanks::sum(int rank, double value) {
  double total = 0.0;
  for (const double v : gather(rank, {value})) total += v;
  return total;
}

double EmulatedRanks::max(int rank, double value) {
  const std::vector<double> all = gather(rank, {value});
  return *std::max_element(all.begin(), all.end());
}

void EmulatedRanks::share(int rank, const std::vector<int>& owner, double* x, std::size_t n) {
  m_slots[static_cast<std::size_t>(rank)].assign(x, x + n);
  m_barrier.arrive_and_wait();
  for (std::size_t k = 0; k < n && k < owner.size(); ++k) {
    const int p = owner[k];
    if (p < 0 || p == rank) continue;
    const std::vector<double>& from = m_slots[static_cast<std::size_t>(p)];
    if (k < from.size()) x[k] = from[k];
  }
  m_barrier.arrive_and_wait();
}

}  // namespace peristat::test
