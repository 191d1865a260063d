// QuasiStaticProblem's tangent: its action (matrix-free) and the dropping of its factors
// while a preconditioner is set up, the assembled tangent, and the bond preconditioner's matrix
// and its contact zone's rows.
#include <stdexcept>
#include <vector>

#include "assembly/column_writer.hpp"
#include "assembly/contact_zone.hpp"
#include "assembly/quasi_static.hpp"
#include "core/huge_pages.hpp"

namespace peristat {

bool QuasiStaticProblem::suspend_action() {
  const Index broken = m_failure ? m_failure->broken() : 0;
  const bool at_tangent = m_tangent_evaluation == m_evaluations;
  if (!m_options.matrix_free || m_action_suspended || m_model.bonds.neighbour.size() < m_suspend_bonds ||
      m_tangent_evaluation == 0 || broken != m_tangent_broken || m_own_rows_only ||
      (!at_tangent && m_u_tangent_evaluation != m_tangent_evaluation))
    return false;
  // The state the factors were made at: m_u now, or the one kept when the first evaluation
  // without a tangent followed (the predictor's, a line search's).
  if (at_tangent) keep_tangent_state();
  decltype(m_s)().swap(m_s);
  decltype(m_kbond)().swap(m_kbond);
  decltype(m_s32)().swap(m_s32);
  decltype(m_kbond32)().swap(m_kbond32);
  m_action.release_float_copy();
  m_action_suspended = true;
  return true;
}

void QuasiStaticProblem::keep_tangent_state() {
  m_u_tangent = m_u;
  m_u_tangent_evaluation = m_tangent_evaluation;
}

void QuasiStaticProblem::restore_action_storage() {
  const std::size_t nbonds = m_model.bonds.neighbour.size();
  if (m_options.float_factors) {
    zero_huge_on_threads(m_s32, nbonds);
    zero_huge_on_threads(m_kbond32, nbonds);
  } else {
    zero_huge_on_threads(m_s, nbonds);
    zero_huge_on_threads(m_kbond, nbonds);
  }
  m_action_suspended = false;
}

void QuasiStaticProblem::resume_action() {
  if (!m_action_suspended) return;
  restore_action_storage();
  // The families at the tangent's state, then the last evaluation's laws and energy back:
  // the factors are the bits that evaluate() made (the same kernels on the same state).
  const std::vector<BondForceLaw> law = m_law;
  const double energy = m_energy;
  m_u.swap(m_u_tangent);
  compute_families(true);
  m_u.swap(m_u_tangent);
  m_law = law;
  m_energy = energy;
  m_action.prepare_families(hessians());  // the contact pairs' Jacobians were kept
}

void QuasiStaticProblem::apply_tangent(const VectorXd& v, VectorXd& y) {
  if (m_action_suspended)
    throw std::logic_error("QuasiStaticProblem::apply_tangent: the action is suspended");
  m_action.apply(hessians(), m_contact.get(), m_options.rows, &m_share, m_fragments.unknowns(), v, y);
}

void QuasiStaticProblem::gather_tangent(SparseMatrix& K) const {
  // Column particle p gathers the Hessian blocks (q, p) of every family energy V_i W_i with
  // p in {i} + family(i) (docs/theory/osb.md, "Assembly"):
  //   family of p:         (p,p) += V_p sum_b k_b + bV_p s_p s_p^T,
  //                        (j,p) += -V_p k_b + bV_p s_b s_p^T
  //   family of i ~ p (r = i -> p): (i,p) += -V_i k_r + bV_i s_i s_r^T,  (p,p) += V_i k_r,
  //                        (j,p) += bV_i s_c s_r^T for every bond c = i -> j.
  if (m_options.float_factors)
    throw std::logic_error("QuasiStaticProblem::gather_tangent: float factors are the matrix-free action's");
  const Bonds& bonds = m_model.bonds;
  const Particles& part = m_model.particles;
  const Constraints& cons = m_model.constraints;
#pragma omp parallel
  {
    ColumnWriter col(m_model, m_pattern, K);
    // The blocks (q, p) of column particle p, written into the current column.
    const auto column = [&](Index p) {
      // Family of p.
      const double Vp = part.volume[p], bVp = m_beta_volume[p];
      const Vec2& sp = m_s_self[p];
      col.add_outer(p, bVp, sp, sp);
      for (Index b = bonds.start[p]; b < bonds.start[p + 1]; ++b) {
        const Sym2 kb = bond_block(m_kbond[b], m_s[b]);
        col.add_sym(p, Vp, kb);
        const Index j = bonds.neighbour[b];
        col.add_sym(j, -Vp, kb);
        col.add_outer(j, bVp, m_s[b], sp);
      }
      // Families of the neighbours of p.
      for (Index b = bonds.start[p]; b < bonds.start[p + 1]; ++b) {
        const Index i = bonds.neighbour[b], r = bonds.reverse(p, b);
        // Partitioned bonds: no reverse when i's family is not held; then neither i nor any
        // particle of its family is this rank's row (check_partition()), so nothing is lost.
        if (r < 0) continue;
        const double Vi = part.volume[i], bVi = m_beta_volume[i];
        const Vec2& sr = m_s[r];
        const Sym2 kr = bond_block(m_kbond[r], sr);
        col.add_sym(i, -Vi, kr);
        col.add_outer(i, bVi, m_s_self[i], sr);
        col.add_sym(p, Vi, kr);
        for (Index c = bonds.start[i]; c < bonds.start[i + 1]; ++c)
          col.add_outer(bonds.neighbour[c], bVi, m_s[c], sr);
      }
    };
#pragma omp for schedule(static)
    for (Index p = m_pattern.col_first; p < m_pattern.col_end; ++p) {
      if (!col.begin(p)) continue;
      column(p);
      // Mirror ghosts of p depend on u_p: their columns fold into p's (chain rule).
      if (cons.has_images())
        for (Index k = cons.image_start[p]; k < cons.image_start[p + 1]; ++k) {
          col.fold_image(cons.images[k].sign);
          column(cons.images[k].ghost);
          col.fold_image({1.0, 1.0});
        }
      // Contact pairs of p: d r_p / d u_p = J, d r_other / d u_p = -J.
      if (m_contact)
        for (auto e = m_contact->incident_begin(p); e != m_contact->incident_end(p); ++e)
          col.add_pair(e->other, m_contact->jacobian(e->pair));
      col.end();
    }
  }
}

SparseMatrix QuasiStaticProblem::make_preconditioner() {
  if (!m_preconditioner)
    m_preconditioner = std::make_unique<BondPreconditioner>(
        m_model, m_options.bond_preconditioner, m_contact.get(),
        m_correction.method() == SurfaceCorrectionMethod::none ? nullptr : &m_correction, m_options.rows);
  return m_preconditioner->make_matrix();
}

void QuasiStaticProblem::assemble_preconditioner(SparseMatrix& P) {
  if (!m_preconditioner) make_preconditioner();
  m_preconditioner->assemble(P, m_correction, BondVectors{m_s, m_s32});
  m_fragments.decouple(P);
}

bool QuasiStaticProblem::assemble_contact_zone(SparseMatrix& Pz) {
  const BondPreconditionerOptions& o = m_options.bond_preconditioner;
  // The zone's rows are solved on this process alone: every row must be here.
  if (!m_contact || o.contact_zone_layers == 0 || !m_options.rows.whole()) return false;
  std::vector<char> zone = contact_zone(
      m_model, *m_contact, {o.contact_zone_layers, o.contact_zone_cap, o.bond_radius * m_model.spacing});
  if (zone.empty()) return false;
  if (!m_zone_preconditioner || zone != m_zone || Pz.rows() == 0) {
    // The zone's particles as the rows of "rank 0", the others as another rank's.
    std::vector<int> owner(zone.size());
    for (std::size_t p = 0; p < zone.size(); ++p) owner[p] = zone[p] ? 0 : 1;
    m_zone_preconditioner = std::make_unique<BondPreconditioner>(
        m_model, o, m_contact.get(),
        m_correction.method() == SurfaceCorrectionMethod::none ? nullptr : &m_correction,
        OwnedRows{0, std::move(owner)});
    m_zone.swap(zone);
    Pz = m_zone_preconditioner->make_matrix();
  }
  m_zone_preconditioner->assemble(Pz, m_correction, BondVectors{m_s, m_s32});
  m_fragments.decouple(Pz);
  return true;
}

}  // namespace peristat
