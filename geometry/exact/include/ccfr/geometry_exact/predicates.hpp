#pragma once
/// @file predicates.hpp
/// Exact geometric predicates and certified distance comparisons (CGAL).
///
/// Intersection tests use the Exact_predicates_inexact_constructions_kernel (filtered exact
/// predicates, about 100 ns per triangle pair). Distance comparisons are filtered: the double
/// kernels of distance.hpp decide when the result is far from the threshold, and the
/// Exact_predicates_exact_constructions_kernel decides the rest exactly. All routines accept
/// degenerate input (coincident points, zero-length segments, collinear triangles): a degenerate
/// primitive is treated as the point set it really is (a point or a segment).
#include <cstdint>

#include "ccfr/core/types.hpp"

namespace ccfr::exact {

/// Exact sign of det[b - a, c - a, d - a] (CGAL::orientation): +1 if d lies on the side the
/// normal (b - a) x (c - a) points to, -1 on the other side, 0 if the four points are coplanar.
int orient3d(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d);

/// True iff the closed triangles (a0, a1, a2) and (b0, b1, b2) share a point (touching counts).
bool triangles_intersect(const Vec3& a0, const Vec3& a1, const Vec3& a2, const Vec3& b0, const Vec3& b1,
                         const Vec3& b2);
/// True iff the closed segment (p, q) and the closed triangle (a, b, c) share a point.
bool segment_triangle_intersect(const Vec3& p, const Vec3& q, const Vec3& a, const Vec3& b, const Vec3& c);
/// True iff segment (p, q) properly crosses the interior of triangle (a, b, c): its ends strictly
/// on opposite sides of the triangle's plane and the crossing strictly inside (exact orientation
/// signs). Touching and coplanar contact are left out: they put a vertex-face or edge-edge sub-pair
/// at distance 0, which distance checks see.
bool segment_crosses_triangle(const Vec3& p, const Vec3& q, const Vec3& a, const Vec3& b, const Vec3& c);
/// True iff the closed segments (p0, p1) and (q0, q1) share a point.
bool segments_intersect(const Vec3& p0, const Vec3& p1, const Vec3& q0, const Vec3& q1);

/// Exact sign of dist^2 - threshold_sq (-1, 0, +1), where dist is the Euclidean distance between
/// the primitives given by the double coordinates (taken as exact rationals) and threshold_sq is
/// the double value given.
int compare_point_point_distance_sq(const Vec3& p, const Vec3& q, double threshold_sq);
int compare_point_edge_distance_sq(const Vec3& p, const Vec3& a, const Vec3& b, double threshold_sq);
int compare_point_triangle_distance_sq(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c, double threshold_sq);
int compare_edge_edge_distance_sq(const Vec3& a0, const Vec3& a1, const Vec3& b0, const Vec3& b1, double threshold_sq);

/// The exact squared distances, rounded to the nearest double (tests and diagnostics; each call
/// constructs exact numbers and costs microseconds).
double exact_point_edge_distance_sq(const Vec3& p, const Vec3& a, const Vec3& b);
double exact_point_triangle_distance_sq(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c);
double exact_edge_edge_distance_sq(const Vec3& a0, const Vec3& a1, const Vec3& b0, const Vec3& b1);

/// How many distance comparisons were decided by the exact kernel rather than the double filter,
/// process-wide since start (for measuring the filter; relaxed atomic counter).
std::uint64_t exact_fallback_count();

}  // namespace ccfr::exact
