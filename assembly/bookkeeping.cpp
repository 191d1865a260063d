#include "assembly/bookkeeping.hpp"

namespace peristat {

RankShare::RankShare(const Model& model, const OwnedRows& rows) {
  const Bonds& bonds = model.bonds;
  const Index n = model.particles.size();
  m_force_needed.assign(static_cast<std::size_t>(n), 0);
  m_family_needed.assign(static_cast<std::size_t>(n), 0);
  for (Index q = 0; q < n; ++q) {
    if (!rows.contains(q)) m_other_particles.push_back(q);
    if (!rows.computes(q)) continue;
    m_force_needed[static_cast<std::size_t>(q)] = 1;
    m_family_needed[static_cast<std::size_t>(q)] = 1;
    for (Index b = bonds.start[q]; b < bonds.start[q + 1]; ++b)
      m_family_needed[static_cast<std::size_t>(bonds.neighbour[b])] = 1;
  }
  const std::vector<Index>& free = model.constraints.free_index;
  for (std::size_t c = 0; c < free.size(); ++c)
    if (free[c] >= 0 && !rows.contains(static_cast<Index>(c / 2))) m_other_unknowns.push_back(free[c]);
}

std::size_t RankShare::memory_bytes() const {
  return m_force_needed.capacity() + m_family_needed.capacity() +
         (m_other_unknowns.capacity() + m_other_particles.capacity()) * sizeof(Index);
}

std::vector<Index> read_unknowns(const Constraints& cons, std::vector<char>& read) {
  for (const MirrorImage& im : cons.images)
    if (read[static_cast<std::size_t>(im.ghost)]) read[static_cast<std::size_t>(im.source)] = 1;
  std::vector<Index> unknowns;
  for (std::size_t p = 0; p < read.size(); ++p)
    if (read[p])
      for (std::size_t c = 0; c < 2; ++c)
        if (const Index f = cons.free_index[2 * p + c]; f >= 0) unknowns.push_back(f);
  return unknowns;  // ascending: particles in order, and a particle's two unknowns in order
}

}  // namespace peristat
