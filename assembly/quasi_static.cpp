#include "assembly/quasi_static.hpp"

#include <chrono>

#include <omp.h>

namespace peristat {

namespace {
double now() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}
}  // namespace

QuasiStaticProblem::QuasiStaticProblem(const Model& model, const Scene& scene)
    : m_model(model), m_pattern(build_pattern(model)) {
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
    m_weighted_volume[i] = weighted_volume(std::span(bonds.xi).subspan(b0, nb),
                                           std::span(bonds.weight).subspan(b0, nb));
  }
  const std::size_t nbonds = bonds.neighbour.size();
  m_eta.assign(nbonds, Vec2::Zero());
  m_direction.assign(nbonds, Vec2::Zero());
  m_s.assign(nbonds, Vec2::Zero());
  m_t.assign(nbonds, 0.0);
  m_kbond.assign(nbonds, Sym2{});
  m_s_self.assign(n, Vec2::Zero());
  m_beta_volume.assign(n, 0.0);
  m_energy_density.assign(n, 0.0);
  m_u = VectorXd::Zero(2 * n);
  m_force = VectorXd::Zero(2 * n);
}

void QuasiStaticProblem::set_load_factor(double lambda) { m_lambda = lambda; }

void QuasiStaticProblem::expand(const VectorXd& x, VectorXd& u) const {
  const Constraints& c = m_model.constraints;
  u.resize(static_cast<Index>(c.prescribed.size()));
  for (std::size_t d = 0; d < c.prescribed.size(); ++d)
    u[d] = c.prescribed[d] ? m_lambda * c.value[d] : x[c.free_index[d]];
}

Mat2 QuasiStaticProblem::stress(Index i) const {
  const Bonds& bonds = m_model.bonds;
  Mat2 P = Mat2::Zero();
  for (Index b = bonds.start[i]; b < bonds.start[i + 1]; ++b) P += m_t[b] * m_direction[b] * bonds.xi[b].transpose();
  return P;
}

void QuasiStaticProblem::commit(const VectorXd& /*x*/) {
  // Elastic bonds carry no history; contact and failure (later issues) commit here.
}

void QuasiStaticProblem::evaluate(const VectorXd& x, VectorXd& r, SparseMatrix* K) {
  const double t0 = now();
  expand(x, m_u);
  compute_families(K != nullptr);
  gather_forces();
  const Constraints& c = m_model.constraints;
  r.resize(c.n_free);
  for (std::size_t d = 0; d < c.prescribed.size(); ++d)
    if (!c.prescribed[d]) r[c.free_index[d]] = m_force[d];
  const double t1 = now();
  m_seconds_residual += t1 - t0;
  if (K) {
    gather_tangent(*K);
    m_seconds_tangent += now() - t1;
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
    const Vec2 ui(m_u[2 * i], m_u[2 * i + 1]);
    for (Index b = b0; b < b0 + nb; ++b) {
      const Index j = bonds.neighbour[b];
      m_eta[b] = Vec2(m_u[2 * j], m_u[2 * j + 1]) - ui;
    }
    const FamilyOutputs out{std::span(m_t).subspan(b0, nb), std::span(m_direction).subspan(b0, nb),
                            std::span(m_s).subspan(b0, nb), std::span(m_kbond).subspan(b0, nb)};
    const FamilyResult res =
        osb_family(m_body_constants[p.body[i]], m_weighted_volume[i], std::span(bonds.xi).subspan(b0, nb),
                   std::span(bonds.weight).subspan(b0, nb), std::span(m_eta).subspan(b0, nb), out, want_tangent);
    m_energy_density[i] = res.energy_density;
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

void QuasiStaticProblem::gather_tangent(SparseMatrix& K) const {
  // Column particle p gathers the Hessian blocks (q, p) of every family energy V_i W_i with
  // p in {i} + family(i) (docs/theory/osb.md, "Assembly"):
  //   family of p:         (p,p) += V_p sum_b k_b + bV_p s_p s_p^T,
  //                        (j,p) += -V_p k_b + bV_p s_b s_p^T
  //   family of i ~ p (r = i -> p): (i,p) += -V_i k_r + bV_i s_i s_r^T,  (p,p) += V_i k_r,
  //                        (j,p) += bV_i s_c s_r^T for every bond c = i -> j.
  const Bonds& bonds = m_model.bonds;
  const Particles& part = m_model.particles;
  const Constraints& cons = m_model.constraints;
  const TangentPattern& pat = m_pattern;
  const Index n = part.size();
  const int reach = pat.lattice_reach;
  const int width = 2 * reach + 1;
  const Index* outer = K.outerIndexPtr();
  double* values = K.valuePtr();

#pragma omp parallel
  {
    std::vector<Index> slot(static_cast<std::size_t>(width) * width, -1);
#pragma omp for schedule(static)
    for (Index p = 0; p < n; ++p) {
      const Index col[2] = {cons.free_index[2 * p], cons.free_index[2 * p + 1]};
      if (col[0] < 0 && col[1] < 0) continue;
      const auto& lp = part.lattice[p];
      auto slot_of = [&](Index q) -> Index& {
        const auto& lq = part.lattice[q];
        return slot[static_cast<std::size_t>(lq[0] - lp[0] + reach) * width + (lq[1] - lp[1] + reach)];
      };
      for (Index k = pat.col_start[p]; k < pat.col_start[p + 1]; ++k) slot_of(pat.row_particle[k]) = k;
      for (int c = 0; c < 2; ++c)
        if (col[c] >= 0) std::fill(values + outer[col[c]], values + outer[col[c] + 1], 0.0);

      // Adds the 2x2 block a (row component, column component) at (q, p).
      auto add = [&](Index q, double a00, double a01, double a10, double a11) {
        const Index base = pat.row_offset[slot_of(q)];
        const bool xr = cons.free_index[2 * q] >= 0, yr = cons.free_index[2 * q + 1] >= 0;
        const double a[2][2] = {{a00, a01}, {a10, a11}};
        for (int cp = 0; cp < 2; ++cp) {
          if (col[cp] < 0) continue;
          double* v = values + outer[col[cp]] + base;
          if (xr) v[0] += a[0][cp];
          if (yr) v[xr ? 1 : 0] += a[1][cp];
        }
      };
      auto add_sym = [&](Index q, double scale, const Sym2& k) { add(q, scale * k[0], scale * k[1], scale * k[1], scale * k[2]); };
      auto add_outer = [&](Index q, double scale, const Vec2& a, const Vec2& b) {
        add(q, scale * a.x() * b.x(), scale * a.x() * b.y(), scale * a.y() * b.x(), scale * a.y() * b.y());
      };

      // Family of p.
      const double Vp = part.volume[p], bVp = m_beta_volume[p];
      const Vec2& sp = m_s_self[p];
      add_outer(p, bVp, sp, sp);
      for (Index b = bonds.start[p]; b < bonds.start[p + 1]; ++b) {
        add_sym(p, Vp, m_kbond[b]);
        const Index j = bonds.neighbour[b];
        add_sym(j, -Vp, m_kbond[b]);
        add_outer(j, bVp, m_s[b], sp);
      }
      // Families of the neighbours of p.
      for (Index b = bonds.start[p]; b < bonds.start[p + 1]; ++b) {
        const Index i = bonds.neighbour[b], r = bonds.reverse[b];
        const double Vi = part.volume[i], bVi = m_beta_volume[i];
        const Vec2& sr = m_s[r];
        add_sym(i, -Vi, m_kbond[r]);
        add_outer(i, bVi, m_s_self[i], sr);
        add_sym(p, Vi, m_kbond[r]);
        for (Index c = bonds.start[i]; c < bonds.start[i + 1]; ++c) add_outer(bonds.neighbour[c], bVi, m_s[c], sr);
      }
      for (Index k = pat.col_start[p]; k < pat.col_start[p + 1]; ++k) slot_of(pat.row_particle[k]) = -1;
    }
  }
}

}  // namespace peristat
