#include "assembly/quasi_static.hpp"

#include <omp.h>

#include <algorithm>
#include <cmath>

#include "core/clock.hpp"
#include "materials/failure.hpp"

namespace peristat {

namespace {
std::unique_ptr<ContactSystem> make_contact(const Model& model, const Scene& scene, double& seconds) {
  if (!scene.contact.enabled) return nullptr;
  const double t0 = wall_seconds();
  auto contact = std::make_unique<ContactSystem>(model, scene);
  seconds = wall_seconds() - t0;
  return contact;
}
}  // namespace

QuasiStaticProblem::QuasiStaticProblem(const Model& model, const Scene& scene)
    : m_model(model),
      m_contact(make_contact(model, scene, m_contact_setup_seconds)),
      m_pattern(build_pattern(model, PatternReach::two_horizons, 0.0, m_contact.get())),
      m_bond_radius(scene.solver.bond_preconditioner.bond_radius * scene.discretization.spacing) {
  m_linear = true;
  for (const Body& body : scene.bodies) {
    m_body_constants.push_back(OsbConstants::from(scene.materials.at(body.material)));
    m_linear = m_linear && m_body_constants.back().kinematics == Kinematics::small;
  }
  const Index n = model.particles.size();
  const Bonds& bonds = model.bonds;
  m_weighted_volume.resize(n);
  for (Index i = 0; i < n; ++i) {
    const Index b0 = bonds.start[i], nb = bonds.family_size(i);
    m_weighted_volume[i] =
        weighted_volume(std::span(bonds.xi).subspan(b0, nb), std::span(bonds.weight).subspan(b0, nb));
  }
  const std::size_t nbonds = bonds.neighbour.size();
  m_eta.assign(nbonds, Vec2::Zero());
  m_direction.assign(nbonds, Vec2::Zero());
  m_s.assign(nbonds, Vec2::Zero());
  m_t.assign(nbonds, 0.0);
  m_kbond.assign(nbonds, Sym2{});
  m_s_self.assign(n, Vec2::Zero());
  m_beta_volume.assign(n, 0.0);
  m_u = VectorXd::Zero(2 * n);
  m_force = VectorXd::Zero(2 * n);
  m_weight = bonds.weight;
  m_failure = scene.failure;
  if (m_failure.enabled) {
    const double delta = model.horizon;
    for (std::size_t b = 0; b < scene.bodies.size(); ++b) {
      const Material& mat = scene.materials.at(scene.bodies[b].material);
      const double mu = m_body_constants[b].mu, kappa = mat.E / (2.0 * (1.0 - mat.nu));  // 2D bulk modulus
      m_critical.push_back(m_failure.criterion == FailureCriterion::skew
                               ? critical_skew(m_failure.G_c, mu, delta)
                               : critical_stretch(m_failure.G_c, kappa, mu, delta));
    }
    if (m_failure.criterion == FailureCriterion::skew) {
      m_reference_bond.assign(n, -1);
      for (Index i = 0; i < n; ++i) {
        const Index b0 = bonds.start[i], nb = bonds.family_size(i);
        const Index r = reference_bond(std::span(bonds.xi).subspan(b0, nb), m_failure.direction);
        if (r >= 0) m_reference_bond[i] = b0 + r;
      }
    }
    m_ratio.assign(nbonds, 0.0);
  }
}

void QuasiStaticProblem::set_load_factor(double lambda) {
  m_lambda = lambda;
}

SparseMatrix QuasiStaticProblem::make_tangent() const {
  // One named result on every path, so it is returned without a copy (NRVO): Eigen 3.4's
  // SparseMatrix has no move constructor and a copy would cost seconds on large models.
  SparseMatrix K;
  if (m_pattern.matrix.rows() == n_unknowns() && m_pattern.matrix.nonZeros() > 0) {
    K.swap(m_pattern.matrix);
  } else {
    TangentPattern fresh = build_pattern(m_model, PatternReach::two_horizons, 0.0, m_contact.get());
    K.swap(fresh.matrix);
  }
  return K;
}

void QuasiStaticProblem::expand(const VectorXd& x, VectorXd& u) const {
  const Constraints& c = m_model.constraints;
  u.resize(static_cast<Index>(c.prescribed.size()));
  for (std::size_t d = 0; d < c.prescribed.size(); ++d)
    u[d] = c.prescribed[d] ? m_lambda * c.value[d] : x[c.free_index[d]];
}

Mat2 QuasiStaticProblem::stress(Index i) const {
  const Bonds& bonds = m_model.bonds;
  Mat2 P = Mat2::Zero();
  for (Index b = bonds.start[i]; b < bonds.start[i + 1]; ++b)
    P += m_t[b] * m_direction[b] * bonds.xi[b].transpose();
  return P;
}

void QuasiStaticProblem::commit(const VectorXd& x) {
  // Elastic bonds carry no history; friction slip does (failure will, too).
  if (!m_contact) return;
  expand(x, m_u);
  m_contact->commit(m_u);
}

void QuasiStaticProblem::evaluate(const VectorXd& x, VectorXd& r, SparseMatrix* K) {
  expand(x, m_u);
  compute_families(K != nullptr);
  gather_forces();
  if (m_contact) {
    const double t0 = wall_seconds();
    m_contact->evaluate(m_u, K != nullptr);
    m_contact->add_internal_force(m_force);
    m_force_scale = m_force.norm();
    m_contact_seconds += wall_seconds() - t0;
  }
  const Constraints& c = m_model.constraints;
  r.resize(c.n_free);
  for (std::size_t d = 0; d < c.prescribed.size(); ++d)
    if (!c.prescribed[d]) r[c.free_index[d]] = m_force[d];
  if (K) gather_tangent(*K);
}

void QuasiStaticProblem::family_displacements(Index i) {
  const Bonds& bonds = m_model.bonds;
  const Vec2 ui(m_u[2 * i], m_u[2 * i + 1]);
  for (Index b = bonds.start[i]; b < bonds.start[i + 1]; ++b) {
    const Index j = bonds.neighbour[b];
    m_eta[b] = Vec2(m_u[2 * j], m_u[2 * j + 1]) - ui;
  }
}

void QuasiStaticProblem::compute_families(bool want_tangent) {
  const Bonds& bonds = m_model.bonds;
  const Particles& p = m_model.particles;
  const Index n = p.size();
  double energy = 0.0;
#pragma omp parallel for schedule(static) reduction(+ : energy)
  for (Index i = 0; i < n; ++i) {
    const Index b0 = bonds.start[i], nb = bonds.family_size(i);
    family_displacements(i);
    const FamilyOutputs out{std::span(m_t).subspan(b0, nb), std::span(m_direction).subspan(b0, nb),
                            std::span(m_s).subspan(b0, nb), std::span(m_kbond).subspan(b0, nb)};
    const FamilyResult res = osb_family(
        m_body_constants[p.body[i]], m_weighted_volume[i], std::span(bonds.xi).subspan(b0, nb),
        std::span(m_weight).subspan(b0, nb), std::span(m_eta).subspan(b0, nb), out, want_tangent);
    energy += p.volume[i] * res.energy_density;
    if (want_tangent) {
      Vec2 s = Vec2::Zero();
      for (Index b = b0; b < b0 + nb; ++b) s -= m_s[b];
      m_s_self[i] = s;
      m_beta_volume[i] = res.beta * p.volume[i];
    }
  }
  m_energy = energy;
}

void QuasiStaticProblem::gather_forces() {
  // dPi/du_q = -V_q sum_b t_b M_b (own family) + sum_b V_j t_r M_r (families of neighbours,
  // r the reverse bond j -> q).
  const Bonds& bonds = m_model.bonds;
  const Particles& p = m_model.particles;
  const Index n = p.size();
#pragma omp parallel for schedule(static)
  for (Index q = 0; q < n; ++q) {
    Vec2 f = Vec2::Zero();
    for (Index b = bonds.start[q]; b < bonds.start[q + 1]; ++b) {
      const Index j = bonds.neighbour[b], r = bonds.reverse[b];
      f += p.volume[j] * m_t[r] * m_direction[r] - p.volume[q] * m_t[b] * m_direction[b];
    }
    m_force[2 * q] = f.x();
    m_force[2 * q + 1] = f.y();
  }
  m_force_scale = m_force.norm();
}

namespace {

/// Writes 2x2 blocks (q, p) into the free-dof columns of particle p of a matrix with the
/// given pattern. One per thread; begin(p) prepares the column (zeroes it and fills a table
/// from lattice offset to row position), end() clears the table.
class ColumnWriter {
 public:
  ColumnWriter(const Model& model, const TangentPattern& pattern, SparseMatrix& A)
      : m_part(model.particles),
        m_cons(model.constraints),
        m_pat(pattern),
        m_reach(pattern.lattice_reach),
        m_width(2 * pattern.lattice_reach + 1),
        m_outer(A.outerIndexPtr()),
        m_values(A.valuePtr()),
        m_slot(static_cast<std::size_t>(m_width) * m_width, -1) {}

  /// False when p has no free component (nothing to write).
  bool begin(Index p) {
    m_p = p;
    m_col[0] = m_cons.free_index[2 * p];
    m_col[1] = m_cons.free_index[2 * p + 1];
    if (m_col[0] < 0 && m_col[1] < 0) return false;
    for (Index k = m_pat.col_start[p]; k < m_pat.col_start[p + 1]; ++k) slot(m_pat.row_particle[k]) = k;
    for (int c = 0; c < 2; ++c)
      if (m_col[c] >= 0) std::fill(m_values + m_outer[m_col[c]], m_values + m_outer[m_col[c] + 1], 0.0);
    return true;
  }
  void end() {
    for (Index k = m_pat.col_start[m_p]; k < m_pat.col_start[m_p + 1]; ++k) slot(m_pat.row_particle[k]) = -1;
  }
  /// Adds the block a (row component, column component) at (q, p).
  void add(Index q, double a00, double a01, double a10, double a11) {
    const Index base = m_pat.row_offset[slot(q)];
    const bool xr = m_cons.free_index[2 * q] >= 0, yr = m_cons.free_index[2 * q + 1] >= 0;
    const double a[2][2] = {{a00, a01}, {a10, a11}};
    for (int cp = 0; cp < 2; ++cp) {
      if (m_col[cp] < 0) continue;
      double* v = m_values + m_outer[m_col[cp]] + base;
      if (xr) v[0] += a[0][cp];
      if (yr) v[xr ? 1 : 0] += a[1][cp];
    }
  }
  /// Whether the pattern holds the block (q, p) of the current column p.
  bool has(Index q) const {
    const auto& lq = m_part.lattice[q];
    const auto& lp = m_part.lattice[m_p];
    const int dx = lq[0] - lp[0], dy = lq[1] - lp[1];
    if (std::abs(dx) > m_reach || std::abs(dy) > m_reach) return false;
    return m_slot[static_cast<std::size_t>(dx + m_reach) * m_width + (dy + m_reach)] >= 0;
  }
  void add_sym(Index q, double scale, const Sym2& k) {
    add(q, scale * k[0], scale * k[1], scale * k[1], scale * k[2]);
  }
  void add_outer(Index q, double scale, const Vec2& a, const Vec2& b) {
    add(q, scale * a.x() * b.x(), scale * a.x() * b.y(), scale * a.y() * b.x(), scale * a.y() * b.y());
  }

 private:
  Index& slot(Index q) {
    const auto& lq = m_part.lattice[q];
    const auto& lp = m_part.lattice[m_p];
    return m_slot[static_cast<std::size_t>(lq[0] - lp[0] + m_reach) * m_width + (lq[1] - lp[1] + m_reach)];
  }

  const Particles& m_part;
  const Constraints& m_cons;
  const TangentPattern& m_pat;
  int m_reach, m_width;
  const Index* m_outer;
  double* m_values;
  std::vector<Index> m_slot;
  Index m_p = 0;
  Index m_col[2] = {-1, -1};
};

}  // namespace

void QuasiStaticProblem::gather_tangent(SparseMatrix& K) const {
  // Column particle p gathers the Hessian blocks (q, p) of every family energy V_i W_i with
  // p in {i} + family(i) (docs/theory/osb.md, "Assembly"):
  //   family of p:         (p,p) += V_p sum_b k_b + bV_p s_p s_p^T,
  //                        (j,p) += -V_p k_b + bV_p s_b s_p^T
  //   family of i ~ p (r = i -> p): (i,p) += -V_i k_r + bV_i s_i s_r^T,  (p,p) += V_i k_r,
  //                        (j,p) += bV_i s_c s_r^T for every bond c = i -> j.
  const Bonds& bonds = m_model.bonds;
  const Particles& part = m_model.particles;
  const Index n = part.size();
#pragma omp parallel
  {
    ColumnWriter col(m_model, m_pattern, K);
#pragma omp for schedule(static)
    for (Index p = 0; p < n; ++p) {
      if (!col.begin(p)) continue;
      // Family of p.
      const double Vp = part.volume[p], bVp = m_beta_volume[p];
      const Vec2& sp = m_s_self[p];
      col.add_outer(p, bVp, sp, sp);
      for (Index b = bonds.start[p]; b < bonds.start[p + 1]; ++b) {
        col.add_sym(p, Vp, m_kbond[b]);
        const Index j = bonds.neighbour[b];
        col.add_sym(j, -Vp, m_kbond[b]);
        col.add_outer(j, bVp, m_s[b], sp);
      }
      // Families of the neighbours of p.
      for (Index b = bonds.start[p]; b < bonds.start[p + 1]; ++b) {
        const Index i = bonds.neighbour[b], r = bonds.reverse[b];
        const double Vi = part.volume[i], bVi = m_beta_volume[i];
        const Vec2& sr = m_s[r];
        col.add_sym(i, -Vi, m_kbond[r]);
        col.add_outer(i, bVi, m_s_self[i], sr);
        col.add_sym(p, Vi, m_kbond[r]);
        for (Index c = bonds.start[i]; c < bonds.start[i + 1]; ++c)
          col.add_outer(bonds.neighbour[c], bVi, m_s[c], sr);
      }
      // Contact pairs of p: d r_p / d u_p = J, d r_other / d u_p = -J.
      if (m_contact) {
        for (auto e = m_contact->incident_begin(p); e != m_contact->incident_end(p); ++e) {
          const Mat2& J = m_contact->jacobian(e->pair);
          col.add(p, J(0, 0), J(0, 1), J(1, 0), J(1, 1));
          col.add(e->other, -J(0, 0), -J(0, 1), -J(1, 0), -J(1, 1));
        }
      }
      col.end();
    }
  }
}

SparseMatrix QuasiStaticProblem::make_preconditioner() const {
  if (!m_bond_pattern)
    m_bond_pattern = std::make_unique<TangentPattern>(
        build_pattern(m_model, PatternReach::bonds_within, m_bond_radius, m_contact.get()));
  return m_bond_pattern->matrix;
}

void QuasiStaticProblem::assemble_preconditioner(SparseMatrix& P) {
  // P = sum over bonds b = i -> j with |xi_b| <= bond_radius dx of V_i alpha'_i omega w_b
  // (g_b g_b^T), g_b the gradient of the extension: the material bond part of the tangent
  // without the rank-one dilatation coupling, on a short stencil whose alpha' = 8 mu / m'
  // keeps the long-wave stiffness. Positive semi-definite bond by bond, definite once
  // rigid motions are prescribed.
  if (!m_bond_pattern) make_preconditioner();
  const Bonds& bonds = m_model.bonds;
  const Particles& part = m_model.particles;
  const Index n = part.size();
  const double r2 = m_bond_radius * m_bond_radius * (1.0 + 1e-9);
  if (m_bond_alpha_volume.empty()) {
    m_bond_alpha_volume.resize(n);
    for (Index i = 0; i < n; ++i) {
      double m = 0.0;
      for (Index b = bonds.start[i]; b < bonds.start[i + 1]; ++b)
        if (bonds.xi[b].squaredNorm() <= r2) m += bonds.weight[b] * bonds.xi[b].squaredNorm();
      m_bond_alpha_volume[i] = m > 0.0 ? 8.0 * m_body_constants[part.body[i]].mu / m * part.volume[i] : 0.0;
    }
  }
#pragma omp parallel
  {
    ColumnWriter col(m_model, *m_bond_pattern, P);
#pragma omp for schedule(static)
    for (Index p = 0; p < n; ++p) {
      if (!col.begin(p)) continue;
      for (Index b = bonds.start[p]; b < bonds.start[p + 1]; ++b) {
        if (bonds.xi[b].squaredNorm() > r2) continue;
        const Index j = bonds.neighbour[b], r = bonds.reverse[b];
        const double k = m_bond_alpha_volume[p] * m_weight[b] + m_bond_alpha_volume[j] * m_weight[r];
        const Vec2& M = m_direction[b];
        col.add_outer(p, k, M, M);
        col.add_outer(j, -k, M, M);
      }
      if (m_contact) {
        for (auto e = m_contact->incident_begin(p); e != m_contact->incident_end(p); ++e) {
          // Pairs added at run time (broken bonds) longer than the preconditioner's stencil
          // have no block in its pattern; the preconditioner does without them.
          if (!col.has(e->other)) continue;
          const Mat2 S = m_contact->preconditioner_block(e->pair);
          col.add(p, S(0, 0), S(0, 1), S(1, 0), S(1, 1));
          col.add(e->other, -S(0, 0), -S(0, 1), -S(1, 0), -S(1, 1));
        }
      }
      col.end();
    }
  }
}

void QuasiStaticProblem::add_stiffness_bound(VectorXd& row_sums) const {
  if (!m_contact) return;
  const std::vector<Index>& free = m_model.constraints.free_index;
  for (Index k = 0; k < m_contact->size(); ++k) {
    const ContactPair& c = m_contact->pairs()[k];
    const double b = 4.0 * m_contact->stiffness_bound(k);
    for (Index p : {c.i, c.j})
      for (int d = 0; d < 2; ++d)
        if (const Index f = free[2 * p + d]; f >= 0) row_sums[f] += b;
  }
}

void QuasiStaticProblem::set_velocity(const VectorXd& v) {
  if (!wants_velocity()) return;
  const std::vector<Index>& free = m_model.constraints.free_index;
  m_velocity.resize(static_cast<Index>(free.size()));
  for (std::size_t c = 0; c < free.size(); ++c) m_velocity[c] = free[c] >= 0 ? v[free[c]] : 0.0;
  m_contact->set_velocity(m_velocity);
}

Index QuasiStaticProblem::break_bonds(const VectorXd& x, Index at_most) {
  m_last_round.clear();
  if (!m_failure.enabled) return 0;
  expand(x, m_u);
  const Bonds& bonds = m_model.bonds;
  const Particles& p = m_model.particles;
  const Index n = p.size();
  const bool skew = m_failure.criterion == FailureCriterion::skew;
#pragma omp parallel for schedule(static)
  for (Index i = 0; i < n; ++i) {
    const Index b0 = bonds.start[i], nb = bonds.family_size(i);
    family_displacements(i);
    const double critical = m_critical[p.body[i]];
    if (skew) {
      if (m_reference_bond[i] < 0) continue;
      bond_skews(std::span(bonds.xi).subspan(b0, nb), std::span(m_eta).subspan(b0, nb),
                 m_reference_bond[i] - b0, std::span(m_ratio).subspan(b0, nb));
      for (Index b = b0; b < b0 + nb; ++b) m_ratio[b] /= critical;
    } else {
      for (Index b = b0; b < b0 + nb; ++b) m_ratio[b] = bond_stretch(bonds.xi[b], m_eta[b]) / critical;
    }
  }
  // Candidates: intact pairs (b < reverse) whose larger ratio of the two directions exceeds 1.
  std::vector<std::pair<double, Index>> over;
  for (Index b = 0; b < bonds.n_bonds(); ++b) {
    const Index r = bonds.reverse[b];
    if (b > r || m_weight[b] == 0.0) continue;
    if (p.fictitious[bonds.neighbour[b]] && p.fictitious[bonds.neighbour[r]]) continue;
    const double ratio = std::max(m_ratio[b], m_ratio[r]);
    if (ratio > 1.0) over.emplace_back(ratio, b);
  }
  if (over.empty()) return 0;
  std::sort(over.begin(), over.end(), std::greater<>());
  auto count = std::max<std::size_t>(
      1, static_cast<std::size_t>(std::ceil(m_failure.fraction * static_cast<double>(over.size()))));
  if (at_most > 0) count = std::min(count, static_cast<std::size_t>(at_most));
  std::vector<std::pair<Index, Index>> pairs;
  for (std::size_t k = 0; k < count; ++k) {
    const Index b = over[k].second;
    m_weight[b] = 0.0;
    m_weight[bonds.reverse[b]] = 0.0;
    pairs.emplace_back(bonds.neighbour[bonds.reverse[b]], bonds.neighbour[b]);
    m_last_round.push_back(b);
  }
  // The new faces are contact candidates at once (when the scene models contact).
  if (m_contact) {
    m_contact_before_round = m_contact->size();
    m_contact->add_broken_bonds(pairs, m_u);
  }
  m_broken += static_cast<Index>(count);
  return static_cast<Index>(count);
}

void QuasiStaticProblem::undo_last_break() {
  const Bonds& bonds = m_model.bonds;
  for (const Index b : m_last_round) {
    m_weight[b] = bonds.weight[b];
    m_weight[bonds.reverse[b]] = bonds.weight[bonds.reverse[b]];
  }
  m_broken -= static_cast<Index>(m_last_round.size());
  if (m_contact && !m_last_round.empty()) m_contact->remove_pairs_from(m_contact_before_round);
  m_last_round.clear();
}

void QuasiStaticProblem::damage(VectorXd& d) const {
  const Bonds& bonds = m_model.bonds;
  const Index n = m_model.particles.size();
  d.resize(n);
  for (Index i = 0; i < n; ++i) {
    double all = 0.0, intact = 0.0;
    for (Index b = bonds.start[i]; b < bonds.start[i + 1]; ++b) {
      all += bonds.weight[b];
      intact += m_weight[b];
    }
    d[i] = all > 0.0 ? 1.0 - intact / all : 0.0;
  }
}

}  // namespace peristat
