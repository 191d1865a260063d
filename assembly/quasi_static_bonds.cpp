// QuasiStaticProblem's bond forces: the families' kernels (forces, laws, energy and, with a
// tangent, the factors the action and the assembled tangent read) and their gather into the
// particles' forces; with linearised kinematics and kept factors, the forces as the factors'
// product instead (docs/theory/newton.md, "Matrix-free").
#include <algorithm>
#include <cmath>
#include <limits>
#include <span>

#include <omp.h>

#include "assembly/quasi_static.hpp"

namespace peristat {

void QuasiStaticProblem::family_displacements(Index i, Vec2* eta) const {
  const Bonds& bonds = m_model.bonds;
  for (Index b = bonds.start[i]; b < bonds.start[i + 1]; ++b)
    eta[b - bonds.start[i]] = bond_displacement(i, b);
}

void QuasiStaticProblem::compute_families(bool want_tangent) {
  const Bonds& bonds = m_model.bonds;
  const Particles& p = m_model.particles;
  const Index n = p.size();
  // The families this rank's rows read (every one of a whole model). The energy of the rank's
  // own families and of those without a row (which every rank computes), summed over the ranks
  // once each; a neighbour's family counts on its owner.
  double own_energy = 0.0, unowned_energy = 0.0;
  const OwnedRows& rows = m_options.rows;
  const std::size_t scratch = static_cast<std::size_t>(omp_get_max_threads()) * m_largest_family;
  if (m_eta_scratch.size() < scratch) {  // more threads than at the start
    m_eta_scratch.resize(scratch);
    m_extension_scratch.resize(scratch);
    m_force_scratch.resize(scratch);
    if (m_options.float_factors) {
      m_s_scratch.resize(scratch);
      m_kbond_scratch.resize(scratch);
    }
  }
#pragma omp parallel reduction(+ : own_energy, unowned_energy)
  {
    const std::size_t mine = static_cast<std::size_t>(omp_get_thread_num()) * m_largest_family;
    Vec2* eta = m_eta_scratch.data() + mine;
    double* extension = m_extension_scratch.data() + mine;
#pragma omp for schedule(static)
    for (Index i = 0; i < n; ++i) {
      if (!m_share.family_needed(i)) continue;
      const Index b0 = bonds.start[i], nb = bonds.family_size(i);
      // The bond forces are gathered from the laws: the kernel writes them only as the scratch
      // of its tangent's directions.
      const auto size = static_cast<std::size_t>(nb);
      const bool single = m_options.float_factors;
      const FamilyOutputs out{
          want_tangent ? std::span(m_force_scratch.data() + mine, size) : std::span<Vec2>(),
          std::span(extension, size),
          !want_tangent ? std::span<Vec2>()
          : single      ? std::span(m_s_scratch.data() + mine, size)
                        : std::span(m_s).subspan(b0, nb),
          !want_tangent ? std::span<BondStiffness>()
          : single      ? std::span(m_kbond_scratch.data() + mine, size)
                        : std::span(m_kbond).subspan(b0, nb)};
      const FamilyResult res = run_kernel(i, eta, out, want_tangent);
      m_law[i] = res.law;
      const double e = p.volume[i] * res.energy_density;
      if (rows.contains(i))
        own_energy += e;
      else if (rows.computes(i))  // no owner
        unowned_energy += e;
      if (want_tangent) keep_factors(i, b0, nb, mine, res.beta);
    }
  }
  // Own rows only (a distributed ADR step): a part of the families, not the energy of the
  // model. (Those without a row count on rank 0, inside the sum: every rank gets the same bits,
  // whatever its thread count, so that the energy check decides alike on every rank.)
  m_energy = m_own_rows_only ? std::numeric_limits<double>::quiet_NaN()
                             : m_ranks.sum(rows.rank == 0 ? own_energy + unowned_energy : own_energy);
}

void QuasiStaticProblem::keep_factors(Index i, Index b0, Index nb, std::size_t mine, double beta) {
  Vec2 s = Vec2::Zero();
  double scale2 = 1.0;  // the family's scale squared (float factors), exact: a power of four
  if (m_options.float_factors) {
    // s_b / sigma_i with sigma_i the power of two at or below the family's largest component:
    // exact scaling, then one rounding, and O(1) values whatever the spacing (s_b ~ dx^3, its
    // pair coefficient (a - g) / |s_b|^2 ~ mu / dx^6 would leave single precision's range
    // near dx = 1e-5 m). The action reads s and s_self scaled and beta_i V_i sigma_i^2
    // (FamilyHessians): its products, the pair term (a - g)(s.d)s / |s|^2 included, are
    // unchanged.
    const Vec2* s_kernel = m_s_scratch.data() + mine;
    const BondStiffness* k_kernel = m_kbond_scratch.data() + mine;
    double largest = 0.0;
    for (Index k = 0; k < nb; ++k) largest = std::max(largest, s_kernel[k].cwiseAbs().maxCoeff());
    const int e = largest > 0.0 ? std::ilogb(largest) : 0;
    const double inverse = std::ldexp(1.0, -e);
    scale2 = std::ldexp(1.0, 2 * e);
    Float2* kept = m_s32.data() + b0;
    for (Index k = 0; k < nb; ++k) {
      kept[k] = Float2{static_cast<float>(inverse * s_kernel[k].x()),
                       static_cast<float>(inverse * s_kernel[k].y())};
      m_kbond32[b0 + k] = Float2{static_cast<float>(k_kernel[k][0]), static_cast<float>(k_kernel[k][1])};
    }
    // s_self sums the rounded s_b, so that a rigid translation keeps no action. In a loop of its
    // own, reading the floats back: Debian's GCC 12.2 at -O3 vectorised the rounding, the store
    // and the sum of one loop so that the sum took the unrounded doubles (the rigid-translation
    // test MatrixFree.FloatFactorsGiveTheTangentToSinglePrecision caught it).
    for (Index k = 0; k < nb; ++k) s -= widened(kept[k]);
  } else {
    for (Index b = b0; b < b0 + nb; ++b) s -= m_s[b];
  }
  m_s_self[i] = s;
  m_beta_volume[i] = beta * m_model.particles.volume[i] * scale2;
}

FamilyResult QuasiStaticProblem::run_kernel(Index i, Vec2* eta, const FamilyOutputs& out,
                                            bool want_tangent) const {
  family_displacements(i, eta);
  return m_kernels[m_model.particles.body[i]]->evaluate(
      m_correction.weighted_volume()[i], m_model.family_xi(i), m_correction.family_weights(i),
      std::span<const Vec2>(eta, static_cast<std::size_t>(m_model.bonds.family_size(i))), out, want_tangent);
}

bool QuasiStaticProblem::can_patch_factors() const {
  return m_options.matrix_free && m_small_kinematics && !m_options.float_factors && m_options.rows.whole() &&
         !m_own_rows_only && !m_action_suspended && m_factors_version != ~std::uint64_t{0} &&
         m_factors_version != m_bonds_version && !m_dirty_families.empty() &&
         8 * m_dirty_families.size() <= static_cast<std::size_t>(m_model.particles.size());
}

void QuasiStaticProblem::patch_factors() {
  const Bonds& bonds = m_model.bonds;
  const Particles& p = m_model.particles;
  std::vector<Index>& dirty = m_dirty_families;
  std::sort(dirty.begin(), dirty.end());
  dirty.erase(std::unique(dirty.begin(), dirty.end()), dirty.end());
  const std::size_t most = m_largest_family;
  std::vector<Vec2> eta(most), force(most), s(most);
  std::vector<double> extension(most);
  std::vector<BondStiffness> k(most);
  // The changed families' kernel factors, raw (before the pairs' sums), where a full
  // evaluation puts them; their reverse bonds' raw k from the neighbours' kernels, whose own
  // factors stay. Kept aside by bond until every pair is summed.
  std::vector<std::pair<Index, BondStiffness>> raw;  // (bond, k_b) of both ends of every changed pair
  std::vector<Index> touched = dirty;                // families whose pairs' stiffnesses change
  for (const Index i : dirty) {
    const Index b0 = bonds.start[i], nb = bonds.family_size(i);
    const auto size = static_cast<std::size_t>(nb);
    const FamilyResult res = run_kernel(i, eta.data(),
                                        {std::span(force.data(), size), std::span(extension.data(), size),
                                         std::span(m_s).subspan(b0, nb), std::span(m_kbond).subspan(b0, nb)},
                                        true);
    keep_factors(i, b0, nb, 0, res.beta);
    for (Index b = b0; b < b0 + nb; ++b) raw.emplace_back(b, m_kbond[b]);
  }
  const auto is_dirty = [&](Index j) { return std::binary_search(dirty.begin(), dirty.end(), j); };
  for (const Index i : dirty)
    for (Index b = bonds.start[i]; b < bonds.start[i + 1]; ++b) touched.push_back(bonds.neighbour[b]);
  std::sort(touched.begin(), touched.end());
  touched.erase(std::unique(touched.begin(), touched.end()), touched.end());
  for (const Index j : touched) {
    if (is_dirty(j)) continue;
    const Index b0 = bonds.start[j], nb = bonds.family_size(j);
    const auto size = static_cast<std::size_t>(nb);
    run_kernel(j, eta.data(),
               {std::span(force.data(), size), std::span(extension.data(), size), std::span(s.data(), size),
                std::span(k.data(), size)},
               true);
    for (Index b = b0; b < b0 + nb; ++b)
      if (is_dirty(bonds.neighbour[b])) raw.emplace_back(b, k[static_cast<std::size_t>(b - b0)]);
  }
  std::sort(raw.begin(), raw.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  const auto raw_k = [&](Index b) {
    const auto it =
        std::lower_bound(raw.begin(), raw.end(), b, [](const auto& e, Index v) { return e.first < v; });
    return Vec2((*it).second[0], (*it).second[1]);
  };
  // Each changed pair's stiffnesses as TangentAction::pair_stiffness() makes them, from the
  // family of its lower bond index.
  for (const Index i : dirty)
    for (Index b = bonds.start[i]; b < bonds.start[i + 1]; ++b) {
      const Index r = bonds.reverse(i, b), j = bonds.neighbour[b];
      const Index lo = std::min(b, r), hi = std::max(b, r);
      const Index q = lo == b ? i : j, other = lo == b ? j : i;
      const TangentAction::PairForm f = TangentAction::pair_form(
          p.volume[q], p.volume[other], raw_k(lo), raw_k(hi), m_s[lo].squaredNorm(), m_s[hi].squaredNorm());
      m_kbond[lo] = BondStiffness{f.c_lower, f.g};
      m_kbond[hi] = BondStiffness{f.c_upper, f.g};
    }
  m_action.patch_float_copy(hessians(), touched);
  m_factors_version = m_bonds_version;
  m_dirty_families.clear();
  ++m_factor_patches;
}

void QuasiStaticProblem::bond_forces(bool want_tangent) {
  compute_families(want_tangent);
  gather_forces();
}

bool QuasiStaticProblem::linear_forces() const {
  // With linearised kinematics the bond forces are linear in u and vanish at u = 0, so they
  // are H u with H the families' Hessian at the current bonds: the action's kept factors, made
  // by the kernels at these bonds (m_factors_version), give them in one pass over the bonds,
  // 5 against 19 ms on case 4.4 at dx = 0.01 m (docs/theory/newton.md, "Matrix-free",
  // "Linear bond forces").
  return m_linear_forces_allowed && !m_own_rows_only && factors_current();
}

bool QuasiStaticProblem::factors_current() const {
  return m_options.matrix_free && m_small_kinematics && !m_action_suspended && m_factors_version == m_bonds_version;
}

void QuasiStaticProblem::ensure_laws() {
  if (m_laws_current) return;
  compute_families(false);
  m_laws_current = true;
}

void QuasiStaticProblem::gather_forces() {
  // dPi/du_q = -V_q sum_b t_b M_b (own family) + sum_b V_j t_r M_r (families of neighbours,
  // r the reverse bond j -> q). The bond's kinematics once for both: M_r = -M_b, e_r = e_b,
  // each t from its family's law (BondForceLaw), bit for bit what the family's kernel had.
  const Bonds& bonds = m_model.bonds;
  const Particles& p = m_model.particles;
  const Index n = p.size();
#pragma omp parallel for schedule(static)
  for (Index q = 0; q < n; ++q) {
    Vec2 f = Vec2::Zero();
    if (!m_share.force_needed(q)) {
      m_force[2 * q] = m_force[2 * q + 1] = 0.0;  // another rank's: its families are not computed here
      continue;
    }
    const bool finite = m_finite[static_cast<std::size_t>(p.body[q])];  // bonds stay in a body
    const Index b0 = bonds.start[q];
    const std::span<const double> wq = m_correction.family_weights(q);
    const BondForceLaw& law_q = m_law[q];
    for (Index b = b0; b < bonds.start[q + 1]; ++b) {
      const Index j = bonds.neighbour[b], r = bonds.reverse(q, b);
      const BondKinematics k = bond_kinematics(finite, m_model.xi(q, b), bond_displacement(q, b));
      const Vec2 force_b = law_q.t(wq[b - b0], k.x, k.e) * k.M;
      const Vec2 force_r = m_law[j].t(m_correction.weight(j, r), k.x, k.e) * Vec2(-k.M);
      f += p.volume[j] * force_r - p.volume[q] * force_b;
    }
    m_force[2 * q] = f.x();
    m_force[2 * q + 1] = f.y();
  }
}

}  // namespace peristat
