// Difference measures between two results files (see io/compare.hpp).
#include "io/compare.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>

#include "core/error.hpp"

namespace peristat {
namespace {

std::string format(const char* pattern, double x, double y) {
  char buf[64];
  std::snprintf(buf, sizeof buf, pattern, x, y);
  return buf;
}

/// Sums over a set of particles, turned into DifferenceMeasures by finish().
struct Accumulator {
  Index particles = 0;
  double sum_diff2 = 0.0, sum_b2 = 0.0, max_diff = 0.0, max_b = 0.0;

  void add(const Vec2& du, const Vec2& ub) {
    ++particles;
    sum_diff2 += du.squaredNorm();
    sum_b2 += ub.squaredNorm();
    max_diff = std::max(max_diff, du.norm());
    max_b = std::max(max_b, ub.norm());
  }

  DifferenceMeasures finish() const {
    DifferenceMeasures m;
    m.particles = particles;
    m.norm_diff = std::sqrt(sum_diff2);
    m.norm_b = std::sqrt(sum_b2);
    m.max_b = max_b;
    m.max_abs = max_diff;
    m.absolute = !(m.norm_b > 0.0);
    m.relative_l2 = m.absolute ? m.norm_diff : m.norm_diff / m.norm_b;
    m.max_relative = m.absolute ? m.max_abs : m.max_abs / m.max_b;
    return m;
  }
};

}  // namespace

std::string particle_mismatch(const ParticleTable& a, const std::string& name_a, const ParticleTable& b,
                              const std::string& name_b) {
  const std::size_t n = a.size();
  if (b.size() != n) {
    return name_a + " has " + std::to_string(n) + " particles, " + name_b + " has " +
           std::to_string(b.size());
  }
  // Looks for the first particle where `differs` holds and counts them all.
  auto first_and_count = [n](auto differs) {
    std::size_t first = n, count = 0;
    for (std::size_t i = 0; i < n; ++i) {
      if (!differs(i)) continue;
      if (count++ == 0) first = i;
    }
    return std::pair{first, count};
  };
  auto of_total = [n](std::size_t count) {
    return " (" + std::to_string(count) + " of " + std::to_string(n) + " particles differ)";
  };

  const auto [fict_first, fict_count] =
      first_and_count([&](std::size_t i) { return (a.fictitious[i] != 0) != (b.fictitious[i] != 0); });
  if (fict_count > 0) {
    const bool in_a = a.fictitious[fict_first] != 0;
    return "particle " + std::to_string(fict_first) + " is fictitious in " + (in_a ? name_a : name_b) +
           " but not in " + (in_a ? name_b : name_a) + of_total(fict_count);
  }

  const auto [body_first, body_count] =
      first_and_count([&](std::size_t i) { return a.body[i] != b.body[i]; });
  if (body_count > 0) {
    return "particle " + std::to_string(body_first) + " belongs to body " +
           std::to_string(a.body[body_first]) + " in " + name_a + " and to body " +
           std::to_string(b.body[body_first]) + " in " + name_b + of_total(body_count);
  }

  double largest = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    largest = std::max({largest, a.position[i].norm(), b.position[i].norm()});
  }
  const double tolerance = largest > 0.0 ? 1e-9 * largest : 1e-12;
  const auto [pos_first, pos_count] =
      first_and_count([&](std::size_t i) { return !((a.position[i] - b.position[i]).norm() <= tolerance); });
  if (pos_count > 0) {
    const Vec2& xa = a.position[pos_first];
    const Vec2& xb = b.position[pos_first];
    char distance[64];
    std::snprintf(distance, sizeof distance, "%.3g m apart, tolerance %.3g m", (xa - xb).norm(), tolerance);
    return "particle " + std::to_string(pos_first) + " is at " + format("(%.9g, %.9g)", xa.x(), xa.y()) +
           " in " + name_a + " and at " + format("(%.9g, %.9g)", xb.x(), xb.y()) + " in " + name_b + ", " +
           distance + of_total(pos_count);
  }
  return {};
}

Comparison compare_displacements(const ParticleTable& particles, const VectorXd& u_a, const VectorXd& u_b,
                                 const VectorXd& left_out) {
  const auto size = 2 * static_cast<Eigen::Index>(particles.size());
  if (u_a.size() != size || u_b.size() != size || (left_out.size() != 0 && 2 * left_out.size() != size)) {
    throw InputError("compare: displacement vectors of size " + std::to_string(u_a.size()) + " and " +
                     std::to_string(u_b.size()) + " and " + std::to_string(left_out.size()) + " flags for " +
                     std::to_string(particles.size()) + " particles (expected " + std::to_string(size) + ")");
  }
  Accumulator all;
  std::map<int, Accumulator> bodies;
  Index held = 0;
  for (std::size_t i = 0; i < particles.size(); ++i) {
    if (particles.fictitious[i] != 0) continue;
    if (left_out.size() != 0 && left_out[static_cast<Eigen::Index>(i)] != 0.0) {
      ++held;
      continue;
    }
    const auto k = 2 * static_cast<Eigen::Index>(i);
    const Vec2 ub(u_b[k], u_b[k + 1]);
    const Vec2 du = Vec2(u_a[k], u_a[k + 1]) - ub;
    all.add(du, ub);
    bodies[particles.body[i]].add(du, ub);
  }
  Comparison c;
  c.all = all.finish();
  c.held_left_out = held;
  for (const auto& [index, sums] : bodies) {
    BodyDifference body;
    body.index = index;
    const bool named = index >= 0 && static_cast<std::size_t>(index) < particles.body_names.size() &&
                       !particles.body_names[static_cast<std::size_t>(index)].empty();
    body.name = named ? particles.body_names[static_cast<std::size_t>(index)] : std::to_string(index);
    body.measures = sums.finish();
    c.bodies.push_back(std::move(body));
  }
  return c;
}

void require_same_particles(const ResultsReader& a, const std::string& name_a, const ResultsReader& b,
                            const std::string& name_b) {
  const std::string mismatch = particle_mismatch(a.particles(), name_a, b.particles(), name_b);
  if (!mismatch.empty()) {
    throw InputError(
        name_a + " and " + name_b +
        " do not hold the same particles (compare needs results of the same discretisation): " + mismatch);
  }
}

Comparison compare_results(const ResultsReader& a, const std::string& name_a, int step_a,
                           const ResultsReader& b, const std::string& name_b, int step_b) {
  require_same_particles(a, name_a, b, name_b);
  const VectorXd held = a.held(step_a).cwiseMax(b.held(step_b));
  Comparison c = compare_displacements(b.particles(), a.displacement(step_a), b.displacement(step_b), held);
  if (c.all.particles == 0 && c.held_left_out > 0)  // no verdict from an empty set
    throw InputError(name_a + " (step " + std::to_string(step_a) + ") and " + name_b + " (step " +
                     std::to_string(step_b) +
                     "): every real particle is held as a fragment in one of them, "
                     "so no displacement is left to compare");
  return c;
}

}  // namespace peristat
