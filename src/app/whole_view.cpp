#include "app/whole_view.hpp"

#include <stdexcept>

#include "assembly/pattern.hpp"

namespace peristat {

WholeView::WholeView(const ModelPart& part, const Ranks& ranks)
    : m_part(part), m_ranks(ranks), m_root(ranks.root()) {
  const int rank = ranks.rank();
  // Each particle's row comes from its owner; those without one (held alike by every rank)
  // from rank 0.
  for (std::size_t p = 0; p < part.owner.size(); ++p) {
    if (counted_by(part.owner[p], rank)) {
      m_given.push_back(static_cast<Index>(p));
      m_given_ids.push_back(part.global_id[p]);
    }
  }
  m_owned_unknowns.assign(part.global_unknown.begin(),
                          part.global_unknown.begin() + static_cast<std::ptrdiff_t>(part.n_owned_unknowns));
}

ParticleTable WholeView::particle_table(const Scene& scene) const {
  ParticleTable t;
  const Particles& p = m_part.model.particles;
  struct Row {
    double x, y, volume;
    int body, fictitious;
  };
  std::vector<Row> rows;
  rows.reserve(m_given.size());
  for (const Index i : m_given)
    rows.push_back({p.position[i].x(), p.position[i].y(), p.volume[i], p.body[i], p.fictitious[i] ? 1 : 0});
  const std::vector<Row> table = m_ranks.gather_rows_on_root(std::span<const std::int64_t>(m_given_ids),
                                                             std::span<const Row>(rows), 1, m_part.n_particles_whole);
  if (!m_root) return t;
  const std::size_t n = particles();
  t.position.resize(n);
  t.volume.resize(n);
  t.body.resize(n);
  t.fictitious.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    t.position[i] = Vec2(table[i].x, table[i].y);
    t.volume[i] = table[i].volume;
    t.body[i] = table[i].body;
    t.fictitious[i] = table[i].fictitious;
  }
  for (const Body& b : scene.bodies) t.body_names.push_back(b.name);
  t.spacing = m_part.model.spacing;
  return t;
}

void WholeView::particle_values(const VectorXd& mine, int width, VectorXd& whole) const {
  const auto w = static_cast<std::size_t>(width);
  m_buffer.resize(w * m_given.size());
  for (std::size_t k = 0; k < m_given.size(); ++k)
    for (std::size_t c = 0; c < w; ++c)
      m_buffer[w * k + c] = mine[static_cast<Index>(w) * m_given[k] + static_cast<Index>(c)];
  const std::vector<double> table = m_ranks.gather_rows_on_root(
      std::span<const std::int64_t>(m_given_ids), std::span<const double>(m_buffer), width, m_part.n_particles_whole);
  whole = Eigen::Map<const VectorXd>(table.data(), static_cast<Index>(table.size()));
}

std::vector<double> WholeView::unknowns(const VectorXd& x) const {
  return m_ranks.gather_rows_on_root(std::span<const std::int64_t>(m_owned_unknowns),
                                     std::span<const double>(x.data(), static_cast<std::size_t>(m_part.n_owned_unknowns)),
                                     1, m_part.n_unknowns_whole);
}

VectorXd WholeView::unknowns_from(const std::vector<double>& whole) const {
  const std::vector<double> mine =
      rows_of(std::span<const double>(whole), 1, std::span<const std::int64_t>(m_part.global_unknown));
  return Eigen::Map<const VectorXd>(mine.data(), static_cast<Index>(mine.size()));
}

}  // namespace peristat
