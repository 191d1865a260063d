// probe_line: displacement sampled along a segment of the reference configuration.
//
// Particles sit at the centres of a uniform lattice of spacing h, one lattice per body
// (bodies need not share an origin). A sample point x is interpolated from the body of
// its nearest non-fictitious particle: with lattice coordinates f = (x - o_b) / h,
// i0 = floor(f), t = f - i0, the bilinear weights of the four cell corners are
// (1-tx)(1-ty), tx(1-ty), (1-tx)ty, tx ty -- exact for affine fields. Where corners with a
// non-zero weight are missing (body edges, holes), the present corners are blended with
// inverse-distance weights 1/|x - x_k|^2. Fictitious particles are ignored throughout.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <unordered_map>

#include "core/error.hpp"
#include "io/results.hpp"

namespace peristat {
namespace {

using Key = std::uint64_t;

/// The particles of a probed file span at most this many spacings in x and in y, so that
/// lattice and bucket coordinates fit the 32 bits pack() keeps of each.
constexpr double k_max_cells = 1u << 30;

Key pack(std::int64_t i, std::int64_t j) {
  return (static_cast<Key>(static_cast<std::uint32_t>(i)) << 32) |
         static_cast<Key>(static_cast<std::uint32_t>(j));
}

/// Spatial index over the non-fictitious particles of a results file, built once per probe
/// (a reader has no Model, hence no discretisation LatticeIndex; positions may be any file's).
class ParticleLocator {
 public:
  ParticleLocator(const ParticleTable& particles, double spacing) : m_particles(particles), m_h(spacing) {
    const std::vector<int> real = real_particles();
    if (real.empty()) return;
    build_buckets(real);
    build_body_lattices(real);
  }

  double spacing() const { return m_h; }

  /// Nearest non-fictitious particle within one spacing (lowest index on ties), or -1.
  int nearest(const Vec2& x) const {
    if (m_bucket_range.empty()) return -1;
    // Particles lie within k_max_cells spacings of m_origin (probe_line checks): a point
    // farther out (or NaN) has none within one spacing, and its bucket would not fit an int64.
    const Vec2 cells = (x - m_origin) / m_h;
    if (!(cells.cwiseAbs().maxCoeff() <= 2.0 * k_max_cells)) return -1;
    const std::int64_t bi = bucket_coord(x.x() - m_origin.x());
    const std::int64_t bj = bucket_coord(x.y() - m_origin.y());
    int best = -1;
    double best_d2 = m_h * m_h * (1.0 + 1e-12);
    for (std::int64_t di = -1; di <= 1; ++di) {
      for (std::int64_t dj = -1; dj <= 1; ++dj) {
        const auto it = m_bucket_range.find(pack(bi + di, bj + dj));
        if (it == m_bucket_range.end()) continue;
        for (std::size_t k = it->second.first; k < it->second.second; ++k) {
          const int p = m_bucket_members[k];
          const double d2 = (m_particles.position[static_cast<std::size_t>(p)] - x).squaredNorm();
          if (d2 < best_d2 || (d2 == best_d2 && p < best)) {
            best = p;
            best_d2 = d2;
          }
        }
      }
    }
    return best;
  }

  /// Lattice origin of `body` (a particle position of that body).
  const Vec2& origin(int body) const { return m_bodies.at(body).origin; }

  /// Non-fictitious particle of `body` at lattice node (i, j), or -1.
  int at(int body, std::int64_t i, std::int64_t j) const {
    const auto& nodes = m_bodies.at(body).nodes;
    const auto it = nodes.find(pack(i, j));
    return it == nodes.end() ? -1 : it->second;
  }

 private:
  struct BodyLattice {
    Vec2 origin = Vec2::Zero();
    std::unordered_map<Key, int> nodes;
  };

  std::vector<int> real_particles() const {
    std::vector<int> real;
    for (std::size_t i = 0; i < m_particles.size(); ++i) {
      if (m_particles.fictitious[i] == 0) real.push_back(static_cast<int>(i));
    }
    return real;
  }

  std::int64_t bucket_coord(double offset) const {
    return static_cast<std::int64_t>(std::floor(offset / m_h));
  }

  Key bucket_of(int p) const {
    const Vec2& x = m_particles.position[static_cast<std::size_t>(p)];
    return pack(bucket_coord(x.x() - m_origin.x()), bucket_coord(x.y() - m_origin.y()));
  }

  /// Buckets of size h: every particle within h of a point lies in the 3 x 3 buckets
  /// around it. Members are stored contiguously, sorted by (bucket, index).
  void build_buckets(const std::vector<int>& real) {
    m_origin = m_particles.position[static_cast<std::size_t>(real.front())];
    for (const int p : real) m_origin = m_origin.cwiseMin(m_particles.position[static_cast<std::size_t>(p)]);
    std::vector<std::pair<Key, int>> keyed;
    keyed.reserve(real.size());
    for (const int p : real) keyed.emplace_back(bucket_of(p), p);
    std::sort(keyed.begin(), keyed.end());
    m_bucket_members.reserve(keyed.size());
    for (std::size_t k = 0; k < keyed.size(); ++k) {
      if (k == 0 || keyed[k].first != keyed[k - 1].first) {
        m_bucket_range[keyed[k].first] = {k, k};
      }
      m_bucket_range[keyed[k].first].second = k + 1;
      m_bucket_members.push_back(keyed[k].second);
    }
  }

  void build_body_lattices(const std::vector<int>& real) {
    for (const int p : real) {
      const int b = m_particles.body[static_cast<std::size_t>(p)];
      const Vec2& x = m_particles.position[static_cast<std::size_t>(p)];
      auto [it, inserted] = m_bodies.try_emplace(b);
      it->second.origin = inserted ? x : Vec2(it->second.origin.cwiseMin(x));
    }
    for (const int p : real) {  // ascending index: the first particle of a node wins
      BodyLattice& lattice = m_bodies[m_particles.body[static_cast<std::size_t>(p)]];
      const Vec2 f = (m_particles.position[static_cast<std::size_t>(p)] - lattice.origin) / m_h;
      lattice.nodes.try_emplace(pack(std::llround(f.x()), std::llround(f.y())), p);
    }
  }

  const ParticleTable& m_particles;
  double m_h;
  Vec2 m_origin = Vec2::Zero();
  std::unordered_map<Key, std::pair<std::size_t, std::size_t>> m_bucket_range;
  std::vector<int> m_bucket_members;
  std::unordered_map<int, BodyLattice> m_bodies;
};

Vec2 particle_value(const VectorXd& u, int p) {
  return Vec2(u[2 * static_cast<Eigen::Index>(p)], u[2 * static_cast<Eigen::Index>(p) + 1]);
}

/// Interpolated displacement at x, or NaNs when no particle lies within one spacing.
Vec2 interpolate(const ParticleLocator& index, const ParticleTable& particles, const VectorXd& u,
                 const Vec2& x) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const int nearest = index.nearest(x);
  if (nearest < 0) return Vec2(nan, nan);

  const int body = particles.body[static_cast<std::size_t>(nearest)];
  const Vec2 f = (x - index.origin(body)) / index.spacing();
  const double fi = std::floor(f.x());
  const double fj = std::floor(f.y());
  const double tx = f.x() - fi;
  const double ty = f.y() - fj;
  const auto i0 = static_cast<std::int64_t>(fi);
  const auto j0 = static_cast<std::int64_t>(fj);

  const std::array<int, 4> corner = {index.at(body, i0, j0), index.at(body, i0 + 1, j0),
                                     index.at(body, i0, j0 + 1), index.at(body, i0 + 1, j0 + 1)};
  const std::array<double, 4> bilinear = {(1 - tx) * (1 - ty), tx * (1 - ty), (1 - tx) * ty, tx * ty};
  double missing_weight = 0.0;
  for (std::size_t k = 0; k < 4; ++k) {
    if (corner[k] < 0) missing_weight += bilinear[k];
  }
  if (missing_weight == 0.0) {  // every corner that matters is present
    Vec2 value = Vec2::Zero();
    for (std::size_t k = 0; k < 4; ++k) {
      if (corner[k] >= 0) value += bilinear[k] * particle_value(u, corner[k]);
    }
    return value;
  }

  // Inverse-distance weights of the present corners; a coincident particle wins outright.
  const double coincident = 1e-24 * index.spacing() * index.spacing();
  Vec2 sum = Vec2::Zero();
  double weight_sum = 0.0;
  for (const int p : corner) {
    if (p < 0) continue;
    const double d2 = (particles.position[static_cast<std::size_t>(p)] - x).squaredNorm();
    if (d2 <= coincident) return particle_value(u, p);
    sum += particle_value(u, p) / d2;
    weight_sum += 1.0 / d2;
  }
  if (weight_sum == 0.0) return particle_value(u, nearest);
  return sum / weight_sum;
}

/// A damaged file can hold any positions: each non-fictitious one must be finite and the
/// set must span at most k_max_cells spacings (the locator's keys and integer casts).
void require_lattice_extent(const ParticleTable& particles, double h) {
  Vec2 lo = Vec2::Constant(std::numeric_limits<double>::infinity());
  Vec2 hi = -lo;
  for (std::size_t i = 0; i < particles.size(); ++i) {
    if (particles.fictitious[i] != 0) continue;
    const Vec2& x = particles.position[i];
    if (!x.allFinite()) {
      throw InputError("probe: particle " + std::to_string(i) +
                       " of the results file has a position that is not finite (is the file damaged?)");
    }
    lo = lo.cwiseMin(x);
    hi = hi.cwiseMax(x);
  }
  if (lo.x() <= hi.x() && !(((hi - lo) / h).maxCoeff() <= k_max_cells)) {
    throw InputError(
        "probe: the particles of the results file span more than 2^30 spacings (is the file damaged?)");
  }
}

}  // namespace

std::vector<ProbeSample> probe_line(const ResultsReader& results, int step, Vec2 a, Vec2 b, int n_points) {
  if (n_points < 1) {
    throw InputError("probe: the number of points must be at least 1, got " + std::to_string(n_points));
  }
  const ParticleTable& particles = results.particles();
  const double h = particles.spacing;
  if (!(h > 0.0) || !std::isfinite(h)) {
    throw InputError("probe: the results file has no valid particle spacing (got " + std::to_string(h) + ")");
  }
  require_lattice_extent(particles, h);
  const VectorXd u = results.displacement(step);
  const ParticleLocator index(particles, h);

  const double length = (b - a).norm();
  std::vector<ProbeSample> samples;
  samples.reserve(static_cast<std::size_t>(n_points));
  for (int k = 0; k < n_points; ++k) {
    const double t = n_points == 1 ? 0.0 : static_cast<double>(k) / (n_points - 1);
    const Vec2 x = (k == n_points - 1 && n_points > 1) ? b : Vec2(a + t * (b - a));
    const Vec2 value = interpolate(index, particles, u, x);
    samples.push_back({t * length, x.x(), x.y(), value.x(), value.y()});
  }
  return samples;
}

}  // namespace peristat
