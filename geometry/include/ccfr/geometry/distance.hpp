#pragma once
/// @file distance.hpp
/// Closest points and distances between point, segment and triangle primitives, with the
/// parameters (barycentric coordinates) of the closest points and the closest feature.
/// All routines are total: degenerate input (zero-length edges, zero-area triangles, parallel
/// or collinear edges, coincident points) gives a valid closest pair, never NaN.
#include <algorithm>
#include <cstdint>

#include "ccfr/core/types.hpp"

namespace ccfr {

/// Closest feature of a segment (a, b).
enum class EdgeFeature : std::uint8_t { v0, v1, interior };
/// Closest feature of a triangle (a, b, c); edge eIJ joins vertices I and J.
enum class TriangleFeature : std::uint8_t { v0, v1, v2, e01, e12, e20, interior };

struct PointEdgeResult {
  double t = 0.0;  ///< closest point = a + t (b - a), t in [0, 1]
  Vec3 closest = Vec3::Zero();
  double distance_sq = 0.0;
  EdgeFeature feature = EdgeFeature::v0;
};

struct PointTriangleResult {
  Vec3 bary = Vec3(1, 0, 0);  ///< closest point = bary[0] a + bary[1] b + bary[2] c, bary >= 0, sum 1
  Vec3 closest = Vec3::Zero();
  double distance_sq = 0.0;
  TriangleFeature feature = TriangleFeature::v0;
};

struct EdgeEdgeResult {
  double s = 0.0;  ///< closest point on edge A = a0 + s (a1 - a0), s in [0, 1]
  double t = 0.0;  ///< closest point on edge B = b0 + t (b1 - b0), t in [0, 1]
  Vec3 pa = Vec3::Zero(), pb = Vec3::Zero();
  double distance_sq = 0.0;
  EdgeFeature feature_a = EdgeFeature::v0, feature_b = EdgeFeature::v0;
  bool parallel = false;  ///< the edges are (nearly) parallel: the closest pair is not unique
};

/// Squared distance between two points.
inline double point_point_distance_sq(const Vec3& p, const Vec3& q) { return (p - q).squaredNorm(); }
/// Closest point on segment (a, b) to p. Inline: edge_edge() calls it four times per boundary
/// case and the detection sinks call it for every vertex-edge pair.
inline PointEdgeResult point_edge(const Vec3& p, const Vec3& a, const Vec3& b) {
  PointEdgeResult r;
  const Vec3 d = b - a;
  const double len_sq = d.squaredNorm();
  // A zero-length edge is its vertex v0; the division below would give NaN.
  double t = len_sq > 0.0 ? (p - a).dot(d) / len_sq : 0.0;
  if (!(t > 0.0)) t = 0.0;  // also catches t = NaN from an overflowing dot product
  if (t > 1.0) t = 1.0;
  r.t = t;
  r.feature = t <= 0.0 ? EdgeFeature::v0 : (t >= 1.0 ? EdgeFeature::v1 : EdgeFeature::interior);
  r.closest = r.feature == EdgeFeature::v0 ? a : (r.feature == EdgeFeature::v1 ? b : Vec3(a + t * d));
  r.distance_sq = (p - r.closest).squaredNorm();
  return r;
}
/// Closest point on triangle (a, b, c) to p.
PointTriangleResult point_triangle(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c);
/// Closest points between segments (a0, a1) and (b0, b1).
///
/// Edges well apart in angle (> 1e-3 rad): the stationary point's s clamped to [0, 1], the best t
/// for it clamped, and, if that clamp bit, the best s for the clamped t (exact for the convex
/// distance over the square; proof in the source). Otherwise (nearly parallel or degenerate
/// edges) the best of the four endpoint-segment candidates and, if strictly closer, the interior
/// candidate:
/// with \f$\mathbf{c} = \mathbf{d}_a \times \mathbf{d}_b\f$, \f$\mathbf{d}_a = \mathbf{a}_1 - \mathbf{a}_0\f$,
/// \f$\mathbf{d}_b = \mathbf{b}_1 - \mathbf{b}_0\f$, the point where \f$\mathbf{p}_a - \mathbf{p}_b \parallel
/// \mathbf{c}\f$ has \f$s = ((\mathbf{b}_0 - \mathbf{a}_0)\times\mathbf{d}_b)\cdot\mathbf{c} / \|\mathbf{c}\|^2\f$
/// (Cramer's rule), and t is the projection of \f$\mathbf{p}_a\f$ onto B. \f$\|\mathbf{c}\|^2\f$ replaces
/// \f$\|\mathbf{d}_a\|^2\|\mathbf{d}_b\|^2 - (\mathbf{d}_a\cdot\mathbf{d}_b)^2\f$, which cancels for nearly parallel
/// edges. The closest points are extreme along \f$\mathbf{n} = (\mathbf{p}_a - \mathbf{p}_b)/\|\mathbf{p}_a -
/// \mathbf{p}_b\|\f$
/// (\f$\mathbf{n}\cdot\mathbf{x} \ge \mathbf{n}\cdot\mathbf{p}_a\f$ on A, \f$\le \mathbf{n}\cdot\mathbf{p}_b\f$ on B)
/// up to rounding of n, at every angle between the edges.
EdgeEdgeResult edge_edge(const Vec3& a0, const Vec3& a1, const Vec3& b0, const Vec3& b1);

/// True only if segments (a0, a1) and (b0, b1) are certainly at least \f$\sqrt{\text{reach\_sq}}\f$
/// apart, decided without the closest points: the distance between the two supporting lines,
/// \f$|(\mathbf{b}_0 - \mathbf{a}_0)\cdot\mathbf{c}| / \|\mathbf{c}\|\f$ with \f$\mathbf{c} = \mathbf{d}_a \times
/// \mathbf{d}_b\f$, is a lower bound of the segments' distance. Used where the angle between the
/// edges is above 1e-3 rad and the bound clears reach by a relative 1e-6 (far above its rounding);
/// otherwise false (undecided, the caller runs edge_edge). A filter for the narrow phase, where
/// it settles about 30 % of the edge-edge sub-pairs of a tightly twisted cloth without edge_edge.
inline bool segments_certainly_apart(const Vec3& a0, const Vec3& a1, const Vec3& b0, const Vec3& b1, double reach_sq) {
  const Vec3 da = a1 - a0, db = b1 - b0;
  const Vec3 c = da.cross(db);
  const double cc = c.squaredNorm();
  if (!(cc > 1e-6 * da.squaredNorm() * db.squaredNorm())) return false;  // near-parallel, degenerate or NaN
  const double along = (b0 - a0).dot(c);
  return along * along > reach_sq * cc * (1.0 + 1e-6);
}

namespace detail {
/// The decision shared by the centre-axis filters below: `gap` is the separation of two point sets
/// along the unnormalised axis u (|u|² = `uu`), computed in coordinates local to the pair. Each
/// dot product is off by a few ulps of |u| times the pair's size, so the bound must clear the
/// reach by a relative 1e-6, and pairs more than 1e5 reaches across are left undecided (there the
/// rounding could approach that margin). NaN gives false.
inline bool gap_clears_reach(double gap, double uu, double reach_sq) {
  // Below 1e-290 the product may be subnormal and the relative margin lost: undecided.
  const double need = reach_sq * uu;
  return gap > 0.0 && need >= 1e-290 && gap * gap > need * (1.0 + 1e-6);
}
/// The size condition of gap_clears_reach, checked only once the gap has cleared the reach
/// (written so that no product can overflow).
inline bool small_enough_to_decide(double size_sq, double reach_sq) { return 1e-10 * size_sq <= reach_sq; }
}  // namespace detail

/// True only if segments (a0, a1) and (b0, b1) are certainly at least \f$\sqrt{\text{reach\_sq}}\f$
/// apart, decided by one separating axis: for any direction u, every point of A lies at u·p <=
/// max(u·a0, u·a1) and every point of B at u·p >= min(u·b0, u·b1) (segments' extremes along u
/// are endpoints), so the distance is at least the difference over |u|. The axis joins the
/// midpoints, u = (b0 + b1) - (a0 + a1), which separates most pairs that the boxes let through
/// but the kernel finds out of reach (about 93 % of them in the soft-wire pile, 63 % in the
/// twisting rope) for about 40 instructions against edge_edge's 320 (callgrind, the pile).
/// Complements segments_certainly_apart, which catches crossing pairs whose midpoints lie side by
/// side. False means undecided.
///
/// The kernels work in global coordinates, so where their own rounding exceeds 1e-6 of the reach
/// (coordinates beyond about 1e8 reaches from the origin) a pair this settles can differ from
/// what the kernel would have said at the reach's edge; the bound is then the better answer.
inline bool segments_apart_along_centres(const Vec3& a0, const Vec3& a1, const Vec3& b0, const Vec3& b1,
                                         double reach_sq) {
  // Local to a0: the rounding then scales with the pair's size, not with its distance from the origin.
  const Vec3 p1 = a1 - a0, q0 = b0 - a0, q1 = b1 - a0;
  const Vec3 u = q0 + q1 - p1;
  const double gap = std::min(u.dot(q0), u.dot(q1)) - std::max(0.0, u.dot(p1));
  return detail::gap_clears_reach(gap, u.squaredNorm(), reach_sq) &&
         detail::small_enough_to_decide(std::max({p1.squaredNorm(), q0.squaredNorm(), q1.squaredNorm()}), reach_sq);
}

/// True only if point p and triangle (a, b, c) are certainly at least \f$\sqrt{\text{reach\_sq}}\f$
/// apart, by the separating axis from p to the triangle's centroid (see
/// segments_apart_along_centres). In the twisting rope it settles about half of the
/// vertex-face sub-pairs that the boxes let through, before point_triangle. False means undecided.
inline bool point_triangle_apart_along_centres(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c,
                                               double reach_sq) {
  const Vec3 qa = a - p, qb = b - p, qc = c - p;
  const Vec3 u = qa + qb + qc;
  const double gap = std::min({u.dot(qa), u.dot(qb), u.dot(qc)});
  return detail::gap_clears_reach(gap, u.squaredNorm(), reach_sq) &&
         detail::small_enough_to_decide(std::max({qa.squaredNorm(), qb.squaredNorm(), qc.squaredNorm()}), reach_sq);
}

/// True only if point p and segment (a, b) are certainly at least \f$\sqrt{\text{reach\_sq}}\f$
/// apart, by the separating axis from p to the segment's midpoint (see
/// segments_apart_along_centres). False means undecided.
inline bool point_segment_apart_along_centres(const Vec3& p, const Vec3& a, const Vec3& b, double reach_sq) {
  const Vec3 qa = a - p, qb = b - p;
  const Vec3 u = qa + qb;
  const double gap = std::min(u.dot(qa), u.dot(qb));
  return detail::gap_clears_reach(gap, u.squaredNorm(), reach_sq) &&
         detail::small_enough_to_decide(std::max(qa.squaredNorm(), qb.squaredNorm()), reach_sq);
}

}  // namespace ccfr
