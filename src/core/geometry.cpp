#include "core/geometry.hpp"

#include <algorithm>
#include <utility>

namespace peristat::geometry {

double distance_to_segment(const Vec2& p, const Vec2& a, const Vec2& b) {
  const Vec2 d = b - a;
  const double len2 = d.squaredNorm();
  const double s = len2 > 0.0 ? std::clamp((p - a).dot(d) / len2, 0.0, 1.0) : 0.0;
  return (p - (a + s * d)).norm();
}

namespace {

int orientation(const Vec2& a, const Vec2& b, const Vec2& c) {
  const double z = (b - a).x() * (c - a).y() - (b - a).y() * (c - a).x();
  return (z > 0.0) - (z < 0.0);
}

/// c lies within the bounding box of [a, b] (used once a, b, c are known collinear).
bool within_box(const Vec2& a, const Vec2& b, const Vec2& c) {
  return std::min(a.x(), b.x()) <= c.x() && c.x() <= std::max(a.x(), b.x()) &&
         std::min(a.y(), b.y()) <= c.y() && c.y() <= std::max(a.y(), b.y());
}

}  // namespace

double signed_area(const std::vector<Vec2>& v) {
  double twice = 0.0;
  for (std::size_t k = 0; k < v.size(); ++k) {
    const Vec2& p = v[k];
    const Vec2& q = v[(k + 1) % v.size()];
    twice += p.x() * q.y() - q.x() * p.y();
  }
  return 0.5 * twice;
}

bool segments_touch(const Vec2& a, const Vec2& b, const Vec2& c, const Vec2& d) {
  const int o1 = orientation(a, b, c), o2 = orientation(a, b, d);
  const int o3 = orientation(c, d, a), o4 = orientation(c, d, b);
  if (o1 != o2 && o3 != o4) return true;
  return (o1 == 0 && within_box(a, b, c)) || (o2 == 0 && within_box(a, b, d)) ||
         (o3 == 0 && within_box(c, d, a)) || (o4 == 0 && within_box(c, d, b));
}

bool inside(const std::vector<Vec2>& v, const Vec2& p) {
  bool in = false;
  for (std::size_t k = 0, j = v.size() - 1; k < v.size(); j = k++) {
    const Vec2& a = v[k];
    const Vec2& b = v[j];
    if ((a.y() > p.y()) != (b.y() > p.y()) &&
        p.x() < (b.x() - a.x()) * (p.y() - a.y()) / (b.y() - a.y()) + a.x())
      in = !in;
  }
  return in;
}

bool segment_touches_polygon(const Vec2& a, const Vec2& b, const std::vector<Vec2>& v) {
  if (inside(v, a)) return true;
  for (std::size_t k = 0; k < v.size(); ++k)
    if (segments_touch(a, b, v[k], v[(k + 1) % v.size()])) return true;
  return false;
}

std::pair<int, int> first_self_intersection(const std::vector<Vec2>& v) {
  const int n = static_cast<int>(v.size());
  for (int i = 0; i < n; ++i) {
    for (int j = i + 2; j < n; ++j) {
      if (i == 0 && j == n - 1) continue;  // adjacent through vertex 0
      if (segments_touch(v[i], v[(i + 1) % n], v[j], v[(j + 1) % n])) return {i, j};
    }
  }
  return {-1, -1};
}

}  // namespace peristat::geometry
