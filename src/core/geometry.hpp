// Small planar predicates used to validate scene shapes (exact-sign orientation tests on
// doubles; good enough for input checks, not for the lattice).
#pragma once

#include <utility>
#include <vector>

#include "core/types.hpp"

namespace peristat::geometry {

/// Distance from p to the closed segment [a, b] (a point when a == b).
double distance_to_segment(const Vec2& p, const Vec2& a, const Vec2& b);

/// Shoelace area, > 0 for counter-clockwise vertices.
double signed_area(const std::vector<Vec2>& vertices);

/// Closed segments [a, b] and [c, d] share at least one point.
bool segments_touch(const Vec2& a, const Vec2& b, const Vec2& c, const Vec2& d);

/// Even-odd point-in-polygon test (points on the boundary may go either way).
bool inside(const std::vector<Vec2>& vertices, const Vec2& p);

/// Segment [a, b] intersects the closed polygon (interior or boundary).
bool segment_touches_polygon(const Vec2& a, const Vec2& b, const std::vector<Vec2>& vertices);

/// Index pair (i, j) of two non-adjacent edges that touch, or {-1, -1} if the polygon
/// is simple. Edge k runs from vertex k to vertex k+1.
std::pair<int, int> first_self_intersection(const std::vector<Vec2>& vertices);

}  // namespace peristat::geometry
