#include "ccfr/geometry_exact/predicates.hpp"

#include <CGAL/Exact_predicates_exact_constructions_kernel.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>

#include <algorithm>
#include <atomic>
#include <cmath>

#include "ccfr/geometry/distance.hpp"

namespace ccfr::exact {

namespace {

using K = CGAL::Exact_predicates_inexact_constructions_kernel;
using EK = CGAL::Exact_predicates_exact_constructions_kernel;

std::atomic<std::uint64_t> g_fallbacks{0};

template <class Kernel>
typename Kernel::Point_3 pt(const Vec3& v) {
  return typename Kernel::Point_3(v.x(), v.y(), v.z());
}

// A closed simplex of up to three points reduced to its true dimension, so CGAL's
// non-degenerate predicates apply: 1 point, 2 (distinct) segment ends, or 3 triangle corners.
struct Simplex {
  K::Point_3 p[3];
  int n = 0;
};

Simplex reduce(const Vec3& a, const Vec3& b) {
  Simplex s;
  s.p[0] = pt<K>(a);
  s.p[1] = pt<K>(b);
  s.n = s.p[0] == s.p[1] ? 1 : 2;
  return s;
}

Simplex reduce(const Vec3& a, const Vec3& b, const Vec3& c) {
  Simplex s;
  const K::Point_3 pa = pt<K>(a), pb = pt<K>(b), pc = pt<K>(c);
  if (!CGAL::collinear(pa, pb, pc)) {
    s.p[0] = pa, s.p[1] = pb, s.p[2] = pc, s.n = 3;
    return s;
  }
  // Collinear: the triangle is the segment between its two extreme points (exact ordering test).
  if (CGAL::collinear_are_ordered_along_line(pb, pa, pc))
    s.p[0] = pb, s.p[1] = pc;
  else if (CGAL::collinear_are_ordered_along_line(pa, pb, pc))
    s.p[0] = pa, s.p[1] = pc;
  else
    s.p[0] = pa, s.p[1] = pb;
  s.n = s.p[0] == s.p[1] ? 1 : 2;
  return s;
}

bool intersect(const Simplex& x, const Simplex& y) {
  if (x.n < y.n) return intersect(y, x);
  // Now x.n >= y.n.
  if (y.n == 1) {
    const K::Point_3& q = y.p[0];
    if (x.n == 1) return x.p[0] == q;
    if (x.n == 2) return K::Segment_3(x.p[0], x.p[1]).has_on(q);
    return K::Triangle_3(x.p[0], x.p[1], x.p[2]).has_on(q);
  }
  const K::Segment_3 sy(y.p[0], y.p[1]);
  if (y.n == 2) {
    if (x.n == 2) return CGAL::do_intersect(K::Segment_3(x.p[0], x.p[1]), sy);
    return CGAL::do_intersect(sy, K::Triangle_3(x.p[0], x.p[1], x.p[2]));
  }
  return CGAL::do_intersect(K::Triangle_3(x.p[0], x.p[1], x.p[2]), K::Triangle_3(y.p[0], y.p[1], y.p[2]));
}

// The double kernels are accurate to a few hundred ulps of the local extent for any input the
// degenerate-triangle fallback does not catch; this margin is ~10^7 times larger, so the double
// answer is trusted only when the distance is clearly away from the threshold.
bool decided_by_double(double d2, double threshold_sq, double extent, double magnitude, int& sign) {
  const double margin =
      1e-9 * (extent * extent + threshold_sq) + 1e-12 * magnitude * (extent + std::sqrt(std::max(threshold_sq, 0.0)));
  if (d2 < threshold_sq - margin) {
    sign = -1;
    return true;
  }
  if (d2 > threshold_sq + margin) {
    sign = 1;
    return true;
  }
  g_fallbacks.fetch_add(1, std::memory_order_relaxed);
  return false;
}

template <class... V>
void extent_of(double& extent, double& magnitude, const Vec3& first, const V&... rest) {
  extent = 0.0;
  magnitude = first.cwiseAbs().maxCoeff();
  ((extent = std::max(extent, (rest - first).cwiseAbs().maxCoeff()),
    magnitude = std::max(magnitude, rest.cwiseAbs().maxCoeff())),
   ...);
}

int sign_of(CGAL::Comparison_result r) { return static_cast<int>(r); }

}  // namespace

int orient3d(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d) {
  return static_cast<int>(CGAL::orientation(pt<K>(a), pt<K>(b), pt<K>(c), pt<K>(d)));
}

bool segment_crosses_triangle(const Vec3& p, const Vec3& q, const Vec3& a, const Vec3& b, const Vec3& c) {
  const int sp = orient3d(a, b, c, p), sq = orient3d(a, b, c, q);
  if (sp == 0 || sp != -sq) return false;
  const int s0 = orient3d(p, q, a, b), s1 = orient3d(p, q, b, c), s2 = orient3d(p, q, c, a);
  return s0 != 0 && s0 == s1 && s1 == s2;
}

bool triangles_intersect(const Vec3& a0, const Vec3& a1, const Vec3& a2, const Vec3& b0, const Vec3& b1,
                         const Vec3& b2) {
  return intersect(reduce(a0, a1, a2), reduce(b0, b1, b2));
}

bool segment_triangle_intersect(const Vec3& p, const Vec3& q, const Vec3& a, const Vec3& b, const Vec3& c) {
  return intersect(reduce(p, q), reduce(a, b, c));
}

bool segments_intersect(const Vec3& p0, const Vec3& p1, const Vec3& q0, const Vec3& q1) {
  return intersect(reduce(p0, p1), reduce(q0, q1));
}

int compare_point_point_distance_sq(const Vec3& p, const Vec3& q, double threshold_sq) {
  double e, m;
  extent_of(e, m, p, q);
  int s;
  if (decided_by_double((p - q).squaredNorm(), threshold_sq, e, m, s)) return s;
  return sign_of(CGAL::compare(CGAL::squared_distance(pt<EK>(p), pt<EK>(q)), EK::FT(threshold_sq)));
}

int compare_point_edge_distance_sq(const Vec3& p, const Vec3& a, const Vec3& b, double threshold_sq) {
  double e, m;
  extent_of(e, m, p, a, b);
  int s;
  if (decided_by_double(point_edge(p, a, b).distance_sq, threshold_sq, e, m, s)) return s;
  return sign_of(
      CGAL::compare(CGAL::squared_distance(pt<EK>(p), EK::Segment_3(pt<EK>(a), pt<EK>(b))), EK::FT(threshold_sq)));
}

int compare_point_triangle_distance_sq(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c,
                                       double threshold_sq) {
  double e, m;
  extent_of(e, m, p, a, b, c);
  int s;
  if (decided_by_double(point_triangle(p, a, b, c).distance_sq, threshold_sq, e, m, s)) return s;
  return sign_of(CGAL::compare(CGAL::squared_distance(pt<EK>(p), EK::Triangle_3(pt<EK>(a), pt<EK>(b), pt<EK>(c))),
                               EK::FT(threshold_sq)));
}

int compare_edge_edge_distance_sq(const Vec3& a0, const Vec3& a1, const Vec3& b0, const Vec3& b1, double threshold_sq) {
  double e, m;
  extent_of(e, m, a0, a1, b0, b1);
  int s;
  if (decided_by_double(edge_edge(a0, a1, b0, b1).distance_sq, threshold_sq, e, m, s)) return s;
  return sign_of(CGAL::compare(
      CGAL::squared_distance(EK::Segment_3(pt<EK>(a0), pt<EK>(a1)), EK::Segment_3(pt<EK>(b0), pt<EK>(b1))),
      EK::FT(threshold_sq)));
}

double exact_point_edge_distance_sq(const Vec3& p, const Vec3& a, const Vec3& b) {
  return CGAL::to_double(CGAL::squared_distance(pt<EK>(p), EK::Segment_3(pt<EK>(a), pt<EK>(b))).exact());
}

double exact_point_triangle_distance_sq(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c) {
  return CGAL::to_double(CGAL::squared_distance(pt<EK>(p), EK::Triangle_3(pt<EK>(a), pt<EK>(b), pt<EK>(c))).exact());
}

double exact_edge_edge_distance_sq(const Vec3& a0, const Vec3& a1, const Vec3& b0, const Vec3& b1) {
  return CGAL::to_double(
      CGAL::squared_distance(EK::Segment_3(pt<EK>(a0), pt<EK>(a1)), EK::Segment_3(pt<EK>(b0), pt<EK>(b1))).exact());
}

std::uint64_t exact_fallback_count() { return g_fallbacks.load(std::memory_order_relaxed); }

}  // namespace ccfr::exact
