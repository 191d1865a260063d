#include "materials/surface_correction.hpp"

#include <algorithm>
#include <cmath>
#include <utility>

#include <Eigen/Dense>

#include "core/clock.hpp"
#include "materials/family_kernel.hpp"

namespace peristat {

namespace {
using Vec5 = Eigen::Matrix<double, 5, 1>;
using Mat5 = Eigen::Matrix<double, 5, 5>;

Vec5 as_vec(const std::array<double, 5>& a) { return Vec5(a.data()); }

/// Relative mismatch of the family's fourth moment that still counts as matched.
constexpr double kMomentTolerance = 1e-6;
/// Passes of the bounded least-change solve (each fixes at least one more factor).
constexpr int kMaxBoundPasses = 30;
/// The mark of a factor not held at a bound (SurfaceCorrection::compute_family's `fixed`).
constexpr double kFree = -1.0;

/// The multipliers `lambda` of the bounded least-change solve of a family (moments; xi its
/// bonds' reference vectors, `intact` their weights, 0 when broken), fixing in `fixed` each
/// factor that leaves [kMinInfluence, kMaxInfluence] at the bound; whether any factor was fixed.
bool bounded_multipliers(std::span<const Vec2> xi, std::span<const double> intact, const Vec5& q0,
                         std::vector<double>& fixed, Vec5& lambda) {
  const std::size_t nb = intact.size();
  bool clipped = false;
  for (int pass = 0; pass < kMaxBoundPasses; ++pass) {
    Mat5 G = Mat5::Zero();
    Vec5 r = q0;
    for (std::size_t b = 0; b < nb; ++b) {
      const double a = intact[b] * xi[b].squaredNorm();
      if (a == 0.0) continue;
      const Vec5 q = as_vec(quartic_monomials(xi[b].normalized()));
      const double f = fixed[b];
      if (f != kFree) {
        r -= a * f * q;
      } else {
        r -= a * q;
        G.noalias() += a * q * q.transpose();
      }
    }
    // Minimum-norm solution: a family with fewer than five bond directions has a singular G.
    lambda = G.completeOrthogonalDecomposition().solve(r);
    bool changed = false;
    for (std::size_t b = 0; b < nb; ++b) {
      if (fixed[b] != kFree || intact[b] == 0.0) continue;
      const double omega = 1.0 + as_vec(quartic_monomials(xi[b].normalized())).dot(lambda);
      if (omega < kMinInfluence || omega > kMaxInfluence) {
        fixed[b] = omega < kMinInfluence ? kMinInfluence : kMaxInfluence;
        changed = clipped = true;
      }
    }
    if (!changed) break;
  }
  return clipped;
}
}  // namespace

std::array<double, 5> quartic_monomials(const Vec2& n) {
  const double c = n.x(), s = n.y();
  return {c * c * c * c, c * c * c * s, c * c * s * s, c * s * s * s, s * s * s * s};
}

SurfaceCorrection::SurfaceCorrection(const Model& model, SurfaceCorrectionMethod method,
                                     std::vector<char> counted)
    : m_model(model), m_method(method), m_counted(std::move(counted)) {
  const Stencil& st = model.stencil;
  Vec5 q0 = Vec5::Zero();
  for (std::size_t k = 0; k < st.offset.size(); ++k) {
    const Vec2 xi(st.offset[k][0] * model.spacing, st.offset[k][1] * model.spacing);
    const double a = st.weight[k] * xi.squaredNorm();
    m_m0 += a;
    q0 += a * as_vec(quartic_monomials(xi.normalized()));
  }
  for (int c = 0; c < 5; ++c) m_q0[c] = q0[c];
  const Index n = model.particles.size();
  m_shared.assign(static_cast<std::size_t>(n), 1);
  m_offset.assign(static_cast<std::size_t>(n), -1);
  m_volume.assign(n, 0.0);
  // The weighted volume each family was built with: `none` keeps it when bonds break.
#pragma omp parallel for schedule(static)
  for (Index i = 0; i < n; ++i)
    m_volume[i] = peristat::weighted_volume(model.family_xi(i), model.bonds.weights(i));
  if (method != SurfaceCorrectionMethod::none) update_all({});
}

void SurfaceCorrection::update_all(std::span<const double> intact) {
  const Index n = m_model.particles.size();
  std::vector<Index> all(static_cast<std::size_t>(n));
  for (Index i = 0; i < n; ++i) all[i] = i;
  update(intact, all);
}

void SurfaceCorrection::update(std::span<const double> intact, std::span<const Index> particles) {
  const double t0 = wall_seconds();
  const Bonds& bonds = m_model.bonds;
  SurfaceCorrectionStats total;
  const Index count = static_cast<Index>(particles.size());
#pragma omp parallel
  {
    SurfaceCorrectionStats local, uncounted;
    thread_local std::vector<double> w;
    std::vector<Index> added;           // families that need their own weights for the first time
    std::vector<double> added_weights;  // theirs, one after the other
#pragma omp for schedule(dynamic, 64)
    for (Index k = 0; k < count; ++k) {
      const Index i = particles[k];
      const std::size_t ki = static_cast<std::size_t>(i);
      const Index nb = bonds.family_size(i);
      w.resize(static_cast<std::size_t>(nb));
      compute_family(i, intact, w, m_counted.empty() || m_counted[ki] ? local : uncounted);
      const std::span<const double> model_w = bonds.weights(i);
      if (std::equal(w.begin(), w.end(), model_w.begin())) {
        m_shared[ki] = 1;
      } else if (m_offset[ki] >= 0) {  // storage of its own from an earlier update
        std::copy(w.begin(), w.end(), m_own.begin() + m_offset[ki]);
        m_shared[ki] = 0;
      } else {
        added.push_back(i);
        added_weights.insert(added_weights.end(), w.begin(), w.end());
      }
    }
    // After the loop's barrier: no thread writes m_own while it grows.
#pragma omp critical
    {
      total.families += local.families;
      total.corrected += local.corrected;
      total.clipped += local.clipped;
      total.unmatched += local.unmatched;
      total.min_influence = std::min(total.min_influence, local.min_influence);
      total.max_influence = std::max(total.max_influence, local.max_influence);
      std::size_t at = 0;
      for (const Index i : added) {
        const std::size_t nb = static_cast<std::size_t>(bonds.family_size(i));
        m_offset[static_cast<std::size_t>(i)] = static_cast<Index>(m_own.size());
        m_shared[static_cast<std::size_t>(i)] = 0;
        m_own.insert(m_own.end(), added_weights.begin() + at, added_weights.begin() + at + nb);
        at += nb;
      }
    }
  }
  total.seconds = wall_seconds() - t0;
  m_stats = total;
}

std::vector<double> SurfaceCorrection::bond_weights() const {
  std::vector<double> all;
  all.reserve(static_cast<std::size_t>(m_model.bonds.n_bonds()));
  for (Index i = 0; i < m_model.particles.size(); ++i) {
    const std::span<const double> w = family_weights(i);
    all.insert(all.end(), w.begin(), w.end());
  }
  return all;
}

Index SurfaceCorrection::own_families() const {
  return static_cast<Index>(std::count(m_shared.begin(), m_shared.end(), 0));
}

void SurfaceCorrection::compute_family(Index i, std::span<const double> all_intact, std::span<double> w,
                                       SurfaceCorrectionStats& stats) {
  const Bonds& bonds = m_model.bonds;
  const Index b0 = bonds.start[i];
  const std::size_t nb = static_cast<std::size_t>(bonds.family_size(i));
  const std::span<const double> model_w = bonds.weights(i);
  const std::span<const double> in =
      all_intact.empty() ? model_w : all_intact.subspan(static_cast<std::size_t>(b0), nb);
  ++stats.families;
  if (m_method == SurfaceCorrectionMethod::none) {
    std::copy(in.begin(), in.end(), w.begin());
    return;
  }
  const std::span<const Vec2> xi = m_model.family_xi(i);
  // An interior family with every bond intact keeps omega = 1 exactly.
  bool complete = nb == m_model.stencil.offset.size();
  double m = 0.0;
  for (std::size_t b = 0; b < nb; ++b) {
    complete = complete && in[b] == model_w[b];
    m += in[b] * xi[b].squaredNorm();
  }
  if (complete || m <= 0.0) {
    std::copy(in.begin(), in.end(), w.begin());
    m_volume[i] = m;
    return;
  }
  ++stats.corrected;
  auto record = [&](double omega) {
    stats.min_influence = std::min(stats.min_influence, omega);
    stats.max_influence = std::max(stats.max_influence, omega);
  };

  // moments: least change of omega (in sum a (omega - 1)^2, a = w x^2) subject to
  // sum a omega q = q0, with the factors that leave [kMinInfluence, kMaxInfluence] fixed at
  // the bound and the rest solved again.
  const Vec5 q0 = as_vec(m_q0);
  // fixed[b - b0]: the bound a factor is held at, or kFree. Families hold a few dozen bonds.
  thread_local std::vector<double> fixed;
  fixed.assign(nb, kFree);
  Vec5 lambda = Vec5::Zero();
  stats.clipped += bounded_multipliers(xi, in, q0, fixed, lambda);
  Vec5 moment = Vec5::Zero();
  double volume = 0.0;
  for (std::size_t b = 0; b < nb; ++b) {
    if (in[b] == 0.0) {
      w[b] = 0.0;
      continue;
    }
    const Vec5 q = as_vec(quartic_monomials(xi[b].normalized()));
    const double f = fixed[b];
    const double omega = std::clamp(f != kFree ? f : 1.0 + q.dot(lambda), kMinInfluence, kMaxInfluence);
    record(omega);
    w[b] = omega * in[b];
    const double a = w[b] * xi[b].squaredNorm();
    volume += a;
    moment += a * q;
  }
  if ((moment - q0).norm() > kMomentTolerance * q0.norm()) ++stats.unmatched;
  m_volume[i] = volume;
}

std::size_t SurfaceCorrection::memory_bytes() const {
  return (m_own.capacity() + m_volume.capacity()) * sizeof(double) + m_shared.capacity() +
         m_offset.capacity() * sizeof(Index);
}

}  // namespace peristat
