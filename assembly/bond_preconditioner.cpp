#include "assembly/bond_preconditioner.hpp"

#include "assembly/column_writer.hpp"
#include "materials/osb.hpp"

namespace peristat {

BondPreconditioner::BondPreconditioner(const Model& model, const BondPreconditionerOptions& options,
                                       const ContactSystem* contact, const SurfaceCorrection* weights,
                                       const OwnedRows& owned)
    : m_model(model),
      m_contact(contact),
      m_radius(options.bond_radius * model.spacing),
      m_pattern(build_pattern(model, PatternReach::bonds_within, m_radius, contact, owned)) {
  const Bonds& bonds = model.bonds;
  const Particles& part = model.particles;
  const Index n = part.size();
  const double r2 = m_radius * m_radius * (1.0 + kBondRadiusMargin);
  m_alpha_volume.resize(n);
  for (Index i = 0; i < n; ++i) {
    const Index b0 = bonds.start[i];
    const std::span<const double> w = weights ? weights->family_weights(i) : bonds.weights(i);
    double m = 0.0;
    for (Index b = b0; b < bonds.start[i + 1]; ++b)
      if (const double x2 = model.xi(i, b).squaredNorm(); x2 <= r2) m += w[b - b0] * x2;
    m_alpha_volume[i] =
        m > 0.0 ? 8.0 * shear_modulus(model.bodies[part.body[i]].material) / m * part.volume[i] : 0.0;
  }
}

void BondPreconditioner::assemble(SparseMatrix& P, const SurfaceCorrection& weights,
                                  const BondVectors& s) const {
  const Bonds& bonds = m_model.bonds;
  const double r2 = m_radius * m_radius * (1.0 + kBondRadiusMargin);
#pragma omp parallel
  {
    ColumnWriter col(m_model, m_pattern, P);
#pragma omp for schedule(static)
    for (Index p = m_pattern.col_first; p < m_pattern.col_end; ++p) {
      if (!col.begin(p)) continue;
      const Index b0 = bonds.start[p];
      const std::span<const double> w = weights.family_weights(p);
      for (Index b = b0; b < bonds.start[p + 1]; ++b) {
        const Vec2 xi = m_model.xi(p, b);
        if (xi.squaredNorm() > r2) continue;
        const Index j = bonds.neighbour[b], r = bonds.reverse(p, b);
        // Partitioned bonds: no reverse when j's family is not held; then neither p nor j is
        // this rank's row (a row's neighbours' families are held), so the block is not its.
        if (r < 0) continue;
        const double k = m_alpha_volume[p] * w[b - b0] + m_alpha_volume[j] * weights.weight(j, r);
        const Vec2 sb = s[b], sr = s[r];
        const Vec2 M = sb.squaredNorm() > 0.0   ? sb.normalized()
                       : sr.squaredNorm() > 0.0 ? Vec2(-sr.normalized())
                                                : xi.normalized();
        col.add_outer(p, k, M, M);
        col.add_outer(j, -k, M, M);
      }
      if (m_contact) {
        for (auto e = m_contact->incident_begin(p); e != m_contact->incident_end(p); ++e) {
          // Pairs added at run time (broken bonds) longer than the preconditioner's stencil
          // have no block in its pattern; the preconditioner does without them. A rank's
          // pattern of owned rows stores (other, p) only when `other` is its own: it knows the
          // pair by the transposed block (p, other) when p is (the pattern is symmetric).
          if (!col.has(e->other) && !(m_pattern.partial && m_pattern.holds(p, e->other))) continue;
          col.add_pair(e->other, m_contact->preconditioner_block(e->pair));
        }
      }
      col.end();
    }
  }
}

std::size_t BondPreconditioner::memory_bytes() const {
  return m_pattern.memory_bytes() + m_alpha_volume.capacity() * sizeof(double);
}

}  // namespace peristat
