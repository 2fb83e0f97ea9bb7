// Closest-point kernels against independent long-double references and dense sampling, on
// seeded random input and on degenerate configurations.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>

#include "ccfr/geometry/distance.hpp"
#include "test_support.hpp"

namespace ccfr {
namespace {

using LD = long double;
struct V3L {
  LD x, y, z;
};
V3L L(const Vec3& v) { return {v.x(), v.y(), v.z()}; }
V3L sub(V3L a, V3L b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
V3L add(V3L a, V3L b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
V3L mul(LD s, V3L a) { return {s * a.x, s * a.y, s * a.z}; }
LD dot(V3L a, V3L b) { return a.x * b.x + a.y * b.y + a.z * b.z; }

// Reference point-segment distance in long double.
LD ref_pe(V3L p, V3L a, V3L b) {
  V3L d = sub(b, a);
  LD l = dot(d, d);
  LD t = l > 0 ? dot(sub(p, a), d) / l : 0;
  t = std::clamp<LD>(t, 0, 1);
  V3L q = sub(p, add(a, mul(t, d)));
  return dot(q, q);
}

// Reference point-triangle distance: plane projection if inside (barycentrics from a 2x2 solve),
// else the best edge. A different algorithm from the Voronoi walk under test.
LD ref_pt(V3L p, V3L a, V3L b, V3L c) {
  LD best = std::min({ref_pe(p, a, b), ref_pe(p, b, c), ref_pe(p, c, a)});
  V3L e0 = sub(b, a), e1 = sub(c, a), ap = sub(p, a);
  LD m00 = dot(e0, e0), m01 = dot(e0, e1), m11 = dot(e1, e1);
  LD det = m00 * m11 - m01 * m01;
  if (det > 1e-30L * m00 * m11) {
    LD r0 = dot(e0, ap), r1 = dot(e1, ap);
    LD v = (m11 * r0 - m01 * r1) / det, w = (m00 * r1 - m01 * r0) / det;
    if (v >= 0 && w >= 0 && v + w <= 1) {
      V3L q = sub(p, add(a, add(mul(v, e0), mul(w, e1))));
      best = std::min(best, dot(q, q));
    }
  }
  return best;
}

// Reference segment-segment distance by nested ternary search on the convex function
// f(s) = min_t |A(s) - B(t)|^2 (min over t is the point-segment distance, also convex in s).
LD ref_ee(V3L a0, V3L a1, V3L b0, V3L b1) {
  auto f = [&](LD s) { return ref_pe(add(a0, mul(s, sub(a1, a0))), b0, b1); };
  LD lo = 0, hi = 1;
  for (int it = 0; it < 200; ++it) {
    LD m1 = lo + (hi - lo) / 3, m2 = hi - (hi - lo) / 3;
    if (f(m1) < f(m2))
      hi = m2;
    else
      lo = m1;
  }
  return std::min({f(0), f(1), f((lo + hi) / 2)});
}

Vec3 rand_vec(std::mt19937_64& g, double scale = 1.0) {
  std::uniform_real_distribution<double> u(-scale, scale);
  return Vec3(u(g), u(g), u(g));
}

void expect_close(double got, LD ref, double scale_sq) {
  EXPECT_TRUE(std::isfinite(got));
  EXPECT_NEAR(got, static_cast<double>(ref), 1e-12 * scale_sq + 1e-12 * std::abs(static_cast<double>(ref)));
}

void check_pe(const Vec3& p, const Vec3& a, const Vec3& b) {
  const PointEdgeResult r = point_edge(p, a, b);
  ASSERT_TRUE(r.closest.allFinite());
  EXPECT_GE(r.t, 0.0);
  EXPECT_LE(r.t, 1.0);
  EXPECT_LE((r.closest - (a + r.t * (b - a))).norm(), 1e-12 * (1 + a.norm() + b.norm()));
  EXPECT_DOUBLE_EQ(r.distance_sq, (p - r.closest).squaredNorm());
  const double scale = (p - a).squaredNorm() + (b - a).squaredNorm();
  expect_close(r.distance_sq, ref_pe(L(p), L(a), L(b)), scale);
  if (r.feature == EdgeFeature::v0) EXPECT_EQ(r.t, 0.0);
  if (r.feature == EdgeFeature::v1) EXPECT_EQ(r.t, 1.0);
  if (r.feature == EdgeFeature::interior) EXPECT_TRUE(r.t > 0.0 && r.t < 1.0);
}

void check_pt(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c) {
  const PointTriangleResult r = point_triangle(p, a, b, c);
  ASSERT_TRUE(r.closest.allFinite());
  ASSERT_TRUE(r.bary.allFinite());
  EXPECT_GE(r.bary.minCoeff(), 0.0);
  EXPECT_NEAR(r.bary.sum(), 1.0, 1e-12);
  const double size = (a - b).norm() + (b - c).norm() + (c - a).norm() + (p - a).norm();
  EXPECT_LE((r.closest - (r.bary[0] * a + r.bary[1] * b + r.bary[2] * c)).norm(), 1e-12 * (1 + size));
  expect_close(r.distance_sq, ref_pt(L(p), L(a), L(b), L(c)), size * size);
  switch (r.feature) {
    case TriangleFeature::v0:
      EXPECT_EQ(r.bary[0], 1.0);
      break;
    case TriangleFeature::v1:
      EXPECT_EQ(r.bary[1], 1.0);
      break;
    case TriangleFeature::v2:
      EXPECT_EQ(r.bary[2], 1.0);
      break;
    case TriangleFeature::e01:
      EXPECT_EQ(r.bary[2], 0.0);
      break;
    case TriangleFeature::e12:
      EXPECT_EQ(r.bary[0], 0.0);
      break;
    case TriangleFeature::e20:
      EXPECT_EQ(r.bary[1], 0.0);
      break;
    case TriangleFeature::interior:
      EXPECT_GT(r.bary.minCoeff(), 0.0);
      break;
  }
}

void check_ee(const Vec3& a0, const Vec3& a1, const Vec3& b0, const Vec3& b1) {
  const EdgeEdgeResult r = edge_edge(a0, a1, b0, b1);
  ASSERT_TRUE(r.pa.allFinite() && r.pb.allFinite());
  EXPECT_TRUE(r.s >= 0.0 && r.s <= 1.0);
  EXPECT_TRUE(r.t >= 0.0 && r.t <= 1.0);
  const double size = (a0 - a1).norm() + (b0 - b1).norm() + (a0 - b0).norm();
  EXPECT_LE((r.pa - (a0 + r.s * (a1 - a0))).norm(), 1e-12 * (1 + size));
  EXPECT_LE((r.pb - (b0 + r.t * (b1 - b0))).norm(), 1e-12 * (1 + size));
  EXPECT_NEAR(r.distance_sq, (r.pa - r.pb).squaredNorm(), 1e-15 * (1 + size * size));
  expect_close(r.distance_sq, ref_ee(L(a0), L(a1), L(b0), L(b1)), size * size);
  EXPECT_EQ(r.feature_a == EdgeFeature::v0, r.s == 0.0);
  EXPECT_EQ(r.feature_a == EdgeFeature::v1, r.s == 1.0);
  EXPECT_EQ(r.feature_b == EdgeFeature::v0, r.t == 0.0);
  EXPECT_EQ(r.feature_b == EdgeFeature::v1, r.t == 1.0);
  // Symmetry: swapping the edges gives the same distance and, where unique, the same points.
  const EdgeEdgeResult q = edge_edge(b0, b1, a0, a1);
  EXPECT_NEAR(q.distance_sq, r.distance_sq, 1e-14 * (1 + size * size));
  EXPECT_EQ(q.parallel, r.parallel);
  if (!r.parallel && r.distance_sq > 1e-8 * size * size) {
    EXPECT_LE((q.pa - r.pb).norm(), 1e-6 * (1 + size));
    EXPECT_LE((q.pb - r.pa).norm(), 1e-6 * (1 + size));
  }
}

TEST(Distance, PointEdgeRandom) {
  auto g = test::rng(1);
  for (int i = 0; i < 20000; ++i) check_pe(rand_vec(g), rand_vec(g), rand_vec(g));
}

TEST(Distance, PointEdgeDegenerate) {
  const Vec3 a(0.3, -0.2, 0.1);
  check_pe(Vec3(1, 2, 3), a, a);  // zero-length edge
  check_pe(a, a, a);              // all coincident
  check_pe(a, a, Vec3(1, 1, 1));  // at an endpoint
  const PointEdgeResult r = point_edge(Vec3(5, 0, 0), a, a);
  EXPECT_EQ(r.feature, EdgeFeature::v0);
  EXPECT_EQ(r.t, 0.0);
  const PointEdgeResult mid = point_edge(Vec3(0.5, 1, 0), Vec3(0, 0, 0), Vec3(1, 0, 0));
  EXPECT_EQ(mid.feature, EdgeFeature::interior);
  EXPECT_DOUBLE_EQ(mid.t, 0.5);
  EXPECT_DOUBLE_EQ(mid.distance_sq, 1.0);
  // Tiny and huge scales.
  check_pe(Vec3(1e-300, 0, 0), Vec3(0, 0, 0), Vec3(0, 1e-300, 0));
  check_pe(Vec3(1e150, 0, 0), Vec3(0, 0, 0), Vec3(0, 1e150, 0));
}

TEST(Distance, PointTriangleRandom) {
  auto g = test::rng(2);
  for (int i = 0; i < 20000; ++i) check_pt(rand_vec(g), rand_vec(g), rand_vec(g), rand_vec(g));
}

TEST(Distance, PointTriangleFeatures) {
  const Vec3 a(0, 0, 0), b(1, 0, 0), c(0, 1, 0);
  struct Case {
    Vec3 p;
    TriangleFeature f;
    double d2;
  };
  const Case cases[] = {
      {Vec3(-1, -1, 1), TriangleFeature::v0, 3.0},
      {Vec3(2, -1, 0), TriangleFeature::v1, 2.0},
      {Vec3(-1, 3, 0), TriangleFeature::v2, 5.0},
      {Vec3(0.5, -1, 0), TriangleFeature::e01, 1.0},
      {Vec3(1, 1, 0), TriangleFeature::e12, 0.5},
      {Vec3(-2, 0.5, 0), TriangleFeature::e20, 4.0},
      {Vec3(0.25, 0.25, -2), TriangleFeature::interior, 4.0},
  };
  for (const Case& cs : cases) {
    const PointTriangleResult r = point_triangle(cs.p, a, b, c);
    EXPECT_EQ(r.feature, cs.f) << cs.p.transpose();
    EXPECT_NEAR(r.distance_sq, cs.d2, 1e-14);
    check_pt(cs.p, a, b, c);
  }
}

TEST(Distance, PointTriangleDegenerate) {
  auto g = test::rng(3);
  for (int i = 0; i < 5000; ++i) {
    const Vec3 a = rand_vec(g), b = rand_vec(g), p = rand_vec(g);
    std::uniform_real_distribution<double> u(-1.5, 2.5);
    check_pt(p, a, b, a + u(g) * (b - a));  // collinear, zero area
    check_pt(p, a, a, b);                   // coincident vertices
    check_pt(p, a, b, b);
    check_pt(p, a, a, a);  // a single point
    check_pt(a, a, b, b);  // the point is a vertex
    // Nearly degenerate: height 1e-9 relative.
    const Vec3 n = rand_vec(g).normalized();
    check_pt(p, a, b, 0.5 * (a + b) + 1e-9 * n);
  }
  const PointTriangleResult r = point_triangle(Vec3(0.5, 1, 0), Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(2, 0, 0));
  EXPECT_NEAR(r.distance_sq, 1.0, 1e-15);
  EXPECT_TRUE(r.bary.allFinite());
}

TEST(Distance, PointTriangleOnFace) {
  auto g = test::rng(4);
  std::uniform_real_distribution<double> u(0, 1);
  for (int i = 0; i < 5000; ++i) {
    const Vec3 a = rand_vec(g), b = rand_vec(g), c = rand_vec(g);
    double v = u(g), w = u(g);
    if (v + w > 1) v = 1 - v, w = 1 - w;
    const Vec3 p = (1 - v - w) * a + v * b + w * c;
    const PointTriangleResult r = point_triangle(p, a, b, c);
    EXPECT_LE(r.distance_sq, 1e-24);
  }
}

TEST(Distance, EdgeEdgeRandom) {
  auto g = test::rng(5);
  for (int i = 0; i < 5000; ++i) check_ee(rand_vec(g), rand_vec(g), rand_vec(g), rand_vec(g));
}

TEST(Distance, EdgeEdgeCrossing) {
  const EdgeEdgeResult r = edge_edge(Vec3(-1, 0, 0), Vec3(1, 0, 0), Vec3(0, -1, 0.5), Vec3(0, 1, 0.5));
  EXPECT_FALSE(r.parallel);
  EXPECT_EQ(r.feature_a, EdgeFeature::interior);
  EXPECT_EQ(r.feature_b, EdgeFeature::interior);
  EXPECT_DOUBLE_EQ(r.s, 0.5);
  EXPECT_DOUBLE_EQ(r.t, 0.5);
  EXPECT_DOUBLE_EQ(r.distance_sq, 0.25);
  // Closest pair at an endpoint of B and the interior of A.
  const EdgeEdgeResult q = edge_edge(Vec3(-1, 0, 0), Vec3(1, 0, 0), Vec3(0.25, 2, 1), Vec3(0.25, 5, 1));
  EXPECT_EQ(q.feature_a, EdgeFeature::interior);
  EXPECT_EQ(q.feature_b, EdgeFeature::v0);
  EXPECT_DOUBLE_EQ(q.distance_sq, 5.0);
}

TEST(Distance, EdgeEdgeDegenerate) {
  auto g = test::rng(6);
  std::uniform_real_distribution<double> u(-2, 2);
  for (int i = 0; i < 2000; ++i) {
    const Vec3 a0 = rand_vec(g), a1 = rand_vec(g), off = rand_vec(g);
    const Vec3 d = a1 - a0;
    // Parallel, overlapping or not.
    check_ee(a0, a1, a0 + off + u(g) * d, a0 + off + u(g) * d);
    // Collinear.
    check_ee(a0, a1, a0 + u(g) * d, a0 + u(g) * d);
    // Anti-parallel identical.
    check_ee(a0, a1, a1, a0);
    // Zero-length edges.
    check_ee(a0, a0, rand_vec(g), rand_vec(g));
    check_ee(rand_vec(g), rand_vec(g), a1, a1);
    check_ee(a0, a0, a1, a1);
    check_ee(a0, a0, a0, a0);
    // Shared endpoint.
    check_ee(a0, a1, a1, rand_vec(g));
    // Nearly parallel.
    check_ee(a0, a1, a0 + off, a1 + off + 1e-9 * rand_vec(g));
  }
  const EdgeEdgeResult r = edge_edge(Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0.5, 1, 0), Vec3(2, 1, 0));
  EXPECT_TRUE(r.parallel);
  EXPECT_DOUBLE_EQ(r.distance_sq, 1.0);
  const EdgeEdgeResult z = edge_edge(Vec3(0, 0, 0), Vec3(0, 0, 0), Vec3(0, 0, 0), Vec3(0, 0, 0));
  EXPECT_FALSE(z.parallel);
  EXPECT_EQ(z.distance_sq, 0.0);
}

// The narrow phase's filter may only settle pairs that are truly beyond reach: whenever it says
// "apart", the long-double reference distance is at least reach. Random pairs around reach, skew
// pairs just beyond and just within it, and the degenerate kinds (parallel, collinear, zero length,
// shared endpoint, NaN), which it must leave undecided.
TEST(Distance, SegmentsCertainlyApartNeverRejectsAPairWithinReach) {
  auto g = test::rng(61);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const double reach = 0.02, reach_sq = reach * reach;
  int decided = 0;
  for (int i = 0; i < 200000; ++i) {
    const Vec3 a0 = 0.02 * rand_vec(g), a1 = a0 + 0.03 * rand_vec(g);
    const Vec3 b0 = 0.02 * rand_vec(g), b1 = b0 + 0.03 * rand_vec(g);
    if (!segments_certainly_apart(a0, a1, b0, b1, reach_sq)) continue;
    ++decided;
    ASSERT_GE(ref_ee(L(a0), L(a1), L(b0), L(b1)), static_cast<LD>(reach_sq)) << "pair " << i;
    ASSERT_GE(edge_edge(a0, a1, b0, b1).distance_sq, reach_sq) << "pair " << i;
  }
  EXPECT_GT(decided, 1000);  // the filter does settle pairs: the test is not vacuous
  // Skew edges along x and y, z apart by reach (1 ± 1e-9): within reach never settled, beyond it
  // only outside the 1e-6 margin.
  const Vec3 a0(-1, 0, 0), a1(1, 0, 0);
  for (double f : {1.0 - 1e-9, 1.0, 1.0 + 1e-9, 1.0 + 1e-7})
    EXPECT_FALSE(segments_certainly_apart(a0, a1, Vec3(0, -1, f * reach), Vec3(0, 1, f * reach), reach_sq)) << f;
  EXPECT_TRUE(segments_certainly_apart(a0, a1, Vec3(0, -1, 1.001 * reach), Vec3(0, 1, 1.001 * reach), reach_sq));
  // Lines far apart, segments farther still (the bound is loose but safe).
  EXPECT_TRUE(segments_certainly_apart(a0, a1, Vec3(5, -1, 0.5), Vec3(5, 1, 0.5), reach_sq));
  const Vec3 d = a1 - a0, off(0, 0.5, 0.5), nan(std::nan(""), 0, 0);
  EXPECT_FALSE(segments_certainly_apart(a0, a1, a0 + off, a1 + off, reach_sq));                     // parallel
  EXPECT_FALSE(segments_certainly_apart(a0, a1, a0 + 2 * d, a0 + 3 * d, reach_sq));                 // collinear
  EXPECT_FALSE(segments_certainly_apart(a0, a0, Vec3(0, 0, 1), Vec3(0, 1, 1), reach_sq));           // zero length
  EXPECT_FALSE(segments_certainly_apart(a0, a1, a1, Vec3(0, 1, 1), reach_sq));                      // shared endpoint
  EXPECT_FALSE(segments_certainly_apart(a0, a1, nan, Vec3(0, 1, 1), reach_sq));                     // NaN
  EXPECT_FALSE(segments_certainly_apart(a0, a1, a0 + off, a1 + off + Vec3(0, 0, 1e-9), reach_sq));  // nearly parallel
}

// The centre-axis filters (segments_apart_along_centres and its point-triangle and point-segment
// kin) are separating-axis bounds: whatever they call apart must be at least reach apart by the
// long-double reference, also 1e4 from the origin, where the coordinates' rounding is largest.
// Parallel, collinear, zero-length and coplanar pairs are decided like any other (the bound holds
// for every axis); coincident centres, pairs within reach and NaN must stay undecided.
TEST(Distance, CentreAxisFiltersNeverRejectAPairWithinReach) {
  auto g = test::rng(67);
  const double reach = 0.02, reach_sq = reach * reach;
  int decided_ee = 0, decided_pt = 0, decided_pe = 0;
  for (const double origin : {0.0, 1e4}) {
    for (int i = 0; i < 100000; ++i) {
      const Vec3 o = Vec3::Constant(origin) + 0.02 * rand_vec(g);
      // Every fourth pair degenerate: a zero-length edge, or B parallel to A.
      const Vec3 a0 = o, a1 = i % 4 == 1 ? a0 : Vec3(a0 + 0.03 * rand_vec(g));
      const Vec3 b0 = o + 0.04 * rand_vec(g), b1 = i % 4 == 2 ? Vec3(b0 + (a1 - a0)) : Vec3(b0 + 0.03 * rand_vec(g));
      const Vec3 c = i % 4 == 3 ? Vec3(0.5 * (b0 + b1)) : Vec3(b0 + 0.03 * rand_vec(g));  // zero-area triangle
      if (segments_apart_along_centres(a0, a1, b0, b1, reach_sq)) {
        ++decided_ee;
        ASSERT_GE(ref_ee(L(a0), L(a1), L(b0), L(b1)), static_cast<LD>(reach_sq)) << "pair " << i;
      }
      if (point_triangle_apart_along_centres(a0, b0, b1, c, reach_sq)) {
        ++decided_pt;
        ASSERT_GE(ref_pt(L(a0), L(b0), L(b1), L(c)), static_cast<LD>(reach_sq)) << "pair " << i;
      }
      if (point_segment_apart_along_centres(a0, b0, b1, reach_sq)) {
        ++decided_pe;
        ASSERT_GE(ref_pe(L(a0), L(b0), L(b1)), static_cast<LD>(reach_sq)) << "pair " << i;
      }
    }
  }
  // Not vacuous: each filter settles a good share of these pairs.
  EXPECT_GT(decided_ee, 10000);
  EXPECT_GT(decided_pt, 10000);
  EXPECT_GT(decided_pe, 10000);

  // Parallel segments side by side, z apart by reach (1 ± 1e-9): the axis is exact here, so within
  // reach is never settled and beyond it only outside the 1e-6 margin.
  const Vec3 a0(-0.01, 0, 0), a1(0.01, 0, 0), up(0, 0, 1);
  for (double f : {1.0 - 1e-9, 1.0, 1.0 + 1e-9, 1.0 + 1e-7}) {
    EXPECT_FALSE(segments_apart_along_centres(a0, a1, a0 + f * reach * up, a1 + f * reach * up, reach_sq)) << f;
    EXPECT_FALSE(point_segment_apart_along_centres(Vec3::Zero(), a0 + f * reach * up, a1 + f * reach * up, reach_sq));
  }
  EXPECT_TRUE(segments_apart_along_centres(a0, a1, a0 + 1.001 * reach * up, a1 + 1.001 * reach * up, reach_sq));
  // A point above a triangle's centroid: within reach never, beyond it yes.
  const Vec3 ta(-0.01, -0.01, 0), tb(0.02, -0.01, 0), tc(-0.01, 0.02, 0);
  EXPECT_FALSE(point_triangle_apart_along_centres(0.999 * reach * up, ta, tb, tc, reach_sq));
  EXPECT_TRUE(point_triangle_apart_along_centres(1.001 * reach * up, ta, tb, tc, reach_sq));
  // Crossing segments (an X), coincident midpoints: the axis vanishes, undecided.
  EXPECT_FALSE(segments_apart_along_centres(Vec3(-1, 0, 0), Vec3(1, 0, 0), Vec3(0, -1, 0), Vec3(0, 1, 0), reach_sq));
  // Coincident points, shared endpoints, NaN.
  EXPECT_FALSE(point_segment_apart_along_centres(a0, a0, a0, reach_sq));
  EXPECT_FALSE(segments_apart_along_centres(a0, a1, a1, Vec3(1, 1, 1), reach_sq));
  const Vec3 nan(std::nan(""), 0, 0);
  EXPECT_FALSE(segments_apart_along_centres(a0, a1, nan, Vec3(1, 1, 1), reach_sq));
  EXPECT_FALSE(point_triangle_apart_along_centres(nan, ta, tb, tc, reach_sq));
  EXPECT_FALSE(point_segment_apart_along_centres(Vec3(1, 1, 1), nan, a1, reach_sq));
  // Far apart but across more than 1e5 reaches (a 10 km edge at reach 2 cm): left undecided.
  EXPECT_FALSE(
      segments_apart_along_centres(Vec3(-5e3, 0, 0), Vec3(5e3, 0, 0), Vec3(-5e3, 0, 1), Vec3(5e3, 0, 1), reach_sq));
}

TEST(Distance, NeverNaNOnExtremeInput) {
  const double big = 1e150, tiny = 1e-300;
  const Vec3 o = Vec3::Zero();
  for (double s : {big, tiny}) {
    const Vec3 x(s, 0, 0), y(0, s, 0), z(0, 0, s);
    EXPECT_FALSE(std::isnan(point_triangle(z, o, x, y).distance_sq));
    EXPECT_FALSE(std::isnan(edge_edge(o, x, y, z).distance_sq));
    EXPECT_FALSE(std::isnan(edge_edge(o, x, y, y + x).distance_sq));
    EXPECT_TRUE(point_triangle(z, o, x, y).bary.allFinite());
  }
}

// ---- nearly parallel edges: distance against the long-double reference, and the separating plane ----

/// Checks edge_edge on one pair against ref_ee and the property the narrow phase builds its plane
/// on: with n = (pa - pb)/|pa - pb|, every endpoint x of A has n.(x - pb) >= |pa - pb| and every
/// endpoint of B n.(x - pa) <= -|pa - pb|. The slack is 1e-12 relative plus the rounding of n itself:
/// pa - pb carries an absolute error of a few eps |x|, which tilts n by ~eps |x| / |pa - pb|.
/// Returns the worst violation of the property divided by its slack (<= 1 passes).
double check_ee_plane(const Vec3& a0, const Vec3& a1, const Vec3& b0, const Vec3& b1) {
  const EdgeEdgeResult r = edge_edge(a0, a1, b0, b1);
  const double scale = std::max(
      {a0.cwiseAbs().maxCoeff(), a1.cwiseAbs().maxCoeff(), b0.cwiseAbs().maxCoeff(), b1.cwiseAbs().maxCoeff()});
  const double len = std::max((a1 - a0).norm(), (b1 - b0).norm());
  const double eps = std::numeric_limits<double>::epsilon();
  const double ref = std::sqrt(static_cast<double>(ref_ee(L(a0), L(a1), L(b0), L(b1))));
  const double dist = std::sqrt(r.distance_sq);
  EXPECT_NEAR(dist, ref, 8 * eps * scale)
      << "a0 " << a0.transpose() << " a1 " << a1.transpose() << " b0 " << b0.transpose() << " b1 " << b1.transpose();
  EXPECT_NEAR(r.distance_sq, (r.pa - r.pb).squaredNorm(), 4 * eps * scale * scale);
  EXPECT_LE((r.pa - (a0 + r.s * (a1 - a0))).norm(), 4 * eps * scale);
  EXPECT_LE((r.pb - (b0 + r.t * (b1 - b0))).norm(), 4 * eps * scale);
  const double gap = (r.pa - r.pb).norm();
  if (!(gap > 1e-9 * scale)) return 0.0;  // touching: no normal to check
  const Vec3 n = (r.pa - r.pb) / gap;
  const double tol = len * (1e-12 + 16 * eps * scale / gap) + 8 * eps * std::max(scale, gap);
  double worst = 0.0;
  for (const Vec3& x : {a0, a1}) worst = std::max(worst, (gap - n.dot(x - r.pb)) / tol);
  for (const Vec3& x : {b0, b1}) worst = std::max(worst, (n.dot(x - r.pa) + gap) / tol);
  EXPECT_LE(worst, 1.0) << "endpoint beyond the separating plane; a0 " << a0.transpose() << " a1 " << a1.transpose()
                        << " b0 " << b0.transpose() << " b1 " << b1.transpose();
  return worst;
}

// Edges at angles 1e-12..1e-3 rad in four arrangements: crossing in projection (the interior
// closest pair the old a c - b^2 denominator got wrong), side by side and overlapping, collinear
// with a gap, and touching; both orders of the edges. Fails before the cross-product kernel with
// distance errors up to 3e-2 and endpoints up to 1.5 beyond the plane (scaled by the slack: 1e12).
TEST(Distance, EdgeEdgeNearlyParallel) {
  auto g = test::rng(1234);
  std::uniform_real_distribution<double> u(-1.0, 1.0), u01(0.0, 1.0);
  for (int e = -12; e <= -3; ++e) {
    const double angle = std::pow(10.0, e);
    double worst = 0.0;
    for (int k = 0; k < 400; ++k) {
      const double size = std::pow(10.0, 2.0 * u(g));  // edge lengths 0.01 .. 100
      const Vec3 dir = rand_vec(g).normalized(), side = dir.unitOrthogonal(), up = dir.cross(side);
      const Vec3 dir_b = std::cos(angle) * dir + std::sin(angle) * side;  // B turned by `angle` about `up`
      const Vec3 centre = size * rand_vec(g);
      const double len_a = size * (0.5 + u01(g)), len_b = size * (0.5 + u01(g));
      const double gap = size * std::pow(10.0, -4.0 * u01(g));  // 1e-4 .. 1 of the edge length
      Vec3 a0, a1, b0, b1;
      switch (k % 4) {
        case 0: {  // crossing: the closest pair is interior to both edges (or nearly so)
          a0 = centre - (0.05 + 0.9 * u01(g)) * len_a * dir;
          b0 = centre + gap * up + angle * size * u(g) * side - (0.05 + 0.9 * u01(g)) * len_b * dir_b;
          break;
        }
        case 1: {  // side by side, overlapping or staggered
          a0 = centre;
          b0 = centre + gap * (u(g) * side + up).normalized() + size * u(g) * dir;
          break;
        }
        case 2: {  // collinear up to the angle, with a gap along the line
          a0 = centre;
          b0 = centre + (len_a + gap) * dir;
          break;
        }
        default: {  // touching: B's start point on A
          a0 = centre;
          b0 = centre + u01(g) * len_a * dir;
          break;
        }
      }
      a1 = a0 + len_a * dir;
      b1 = b0 + len_b * dir_b;
      worst = std::max({worst, check_ee_plane(a0, a1, b0, b1), check_ee_plane(b1, b0, a0, a1)});
      if (::testing::Test::HasFailure()) {
        ADD_FAILURE() << "angle " << angle << " case " << k;
        return;
      }
    }
    std::printf("[edge-edge, angle %.0e] worst plane violation / slack %.3f\n", angle, worst);
  }
}

// Zero-length edges and exactly parallel, collinear and crossing edges keep the plane property.
TEST(Distance, EdgeEdgeDegeneratePlane) {
  auto g = test::rng(4321);
  std::uniform_real_distribution<double> u(-2.0, 2.0);
  for (int k = 0; k < 2000; ++k) {
    const Vec3 a0 = rand_vec(g), a1 = rand_vec(g), c = rand_vec(g), off = 0.1 * rand_vec(g);
    const Vec3 d = a1 - a0;
    check_ee_plane(a0, a0, c, c + off);                                       // point vs segment
    check_ee_plane(a0, a1, c, c);                                             // segment vs point
    check_ee_plane(a0, a0, c, c);                                             // point vs point
    check_ee_plane(a0, a1, a0 + off + u(g) * d, a0 + off + u(g) * d);         // exactly parallel
    check_ee_plane(a0, a1, a0 + u(g) * d, a0 + u(g) * d);                     // collinear
    check_ee_plane(a0, a1, a0 + 0.5 * d - off, a0 + 0.5 * d + off);           // crossing at the midpoint
    check_ee_plane(a0, a1, a0 + 0.5 * d + off.cross(d), a0 + 0.5 * d + off);  // skew
  }
}

// Dense sampling gives an upper bound on the true distance; the kernel must never exceed it.
TEST(Distance, NotAboveSampledMinimum) {
  auto g = test::rng(7);
  for (int i = 0; i < 50; ++i) {
    const Vec3 p = rand_vec(g), a = rand_vec(g), b = rand_vec(g), c = rand_vec(g), d = rand_vec(g);
    double best_pt = std::numeric_limits<double>::infinity(), best_ee = best_pt;
    const int n = 120;
    for (int k = 0; k <= n; ++k)
      for (int l = 0; l <= n; ++l) {
        const double s = double(k) / n, t = double(l) / n;
        best_ee = std::min(best_ee, ((a + s * (b - a)) - (c + t * (d - c))).squaredNorm());
        if (k + l <= n) best_pt = std::min(best_pt, (p - ((1 - s - t) * a + s * b + t * c)).squaredNorm());
      }
    EXPECT_LE(point_triangle(p, a, b, c).distance_sq, best_pt + 1e-15);
    EXPECT_LE(edge_edge(a, b, c, d).distance_sq, best_ee + 1e-15);
  }
}

// The dense scenes' edge pairs: short edges at every angle above 1e-3 rad, near each other, most
// with the unconstrained stationary point just outside a side, outside a corner, or far away;
// plus endpoints shared within rounding and far-from-origin coordinates. Against the best of the
// four endpoint-segment tests and the long-double reference.
TEST(Distance, EdgeEdgeShortEdgesNearEachOther) {
  auto g = test::rng(20261124);
  std::uniform_real_distribution<double> u(-1.0, 1.0), u01(0.0, 1.0);
  for (int i = 0; i < 60000; ++i) {
    const double len = std::pow(10.0, -3.0 + 2.0 * u01(g));  // 1 mm .. 10 cm
    const Vec3 origin = i % 3 == 0 ? Vec3(1e3, -1e3, 5e2) : Vec3::Zero();
    const Vec3 a0 = origin + len * rand_vec(g), a1 = a0 + len * rand_vec(g).normalized();
    Vec3 b0 = a0 + 2.0 * len * rand_vec(g), b1 = b0 + len * (1.0 + u01(g)) * rand_vec(g).normalized();
    if (i % 11 == 0) b0 = a1 + Vec3::Constant(1e-13 * len);  // nearly shared endpoint
    const Vec3 da = a1 - a0, db = b1 - b0;
    if (!(da.cross(db).squaredNorm() > 1e-6 * da.squaredNorm() * db.squaredNorm())) continue;
    const EdgeEdgeResult r = edge_edge(a0, a1, b0, b1);
    double best = std::min({point_edge(a0, b0, b1).distance_sq, point_edge(a1, b0, b1).distance_sq,
                            point_edge(b0, a0, a1).distance_sq, point_edge(b1, a0, a1).distance_sq});
    const double scale = origin.norm() + 3.0 * len;
    const double slack = 64 * std::numeric_limits<double>::epsilon() * scale * scale;
    ASSERT_LE(r.distance_sq, best + slack) << "pair " << i;
    ASSERT_NEAR(r.distance_sq, static_cast<double>(ref_ee(L(a0), L(a1), L(b0), L(b1))), slack) << "pair " << i;
    ASSERT_NEAR(r.distance_sq, (r.pa - r.pb).squaredNorm(), slack) << "pair " << i;
  }
}

// The clamped path for edges more than 1e-3 rad apart: the distance of the long-double reference,
// and the separating-plane property the narrow phase builds on (check_ee_plane), over arrangements
// that end on every side and corner of the parameter square: B beside A's end, beyond it, across
// it, at angles from 1e-3 rad (just inside the path) to perpendicular, 1e3 from the origin too.
TEST(Distance, EdgeEdgeClampedPathKeepsTheSeparatingPlane) {
  auto g = test::rng(20261125);
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  int sides[3][3] = {};  // how the result's (s, t) lies: 0 at 0, 1 inside, 2 at 1
  double worst = 0.0;
  for (int i = 0; i < 40000; ++i) {
    const Vec3 origin = i % 4 == 0 ? Vec3(1e3, -2e2, 7e2) : Vec3::Zero();
    const double len = std::pow(10.0, -2.0 + 2.0 * u01(g));
    const Vec3 a0 = origin + len * rand_vec(g), da = len * rand_vec(g).normalized();
    // B's direction: A's turned by an angle from 1.1e-3 rad to pi/2 about a random axis.
    const double angle = i % 5 == 0 ? 1.1e-3 * (1.0 + u01(g)) : 1.5707 * u01(g) + 1.1e-3;
    const Vec3 axis = da.cross(rand_vec(g)).normalized();
    const Vec3 db = (Eigen::AngleAxisd(angle, axis) * da) * (0.5 + u01(g));
    const Vec3 b0 = a0 + (2.0 * u01(g) - 0.5) * da + 0.5 * len * rand_vec(g) - u01(g) * db;
    const Vec3 a1 = a0 + da, b1 = b0 + db;
    if (!(da.cross(db).squaredNorm() > 1e-6 * da.squaredNorm() * db.squaredNorm())) continue;
    worst = std::max(worst, check_ee_plane(a0, a1, b0, b1));
    const EdgeEdgeResult r = edge_edge(a0, a1, b0, b1);
    ++sides[r.s <= 0.0 ? 0 : (r.s >= 1.0 ? 2 : 1)][r.t <= 0.0 ? 0 : (r.t >= 1.0 ? 2 : 1)];
    if (::testing::Test::HasFailure()) break;
  }
  EXPECT_LE(worst, 1.0);
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) EXPECT_GT(sides[i][j], 100) << "s side " << i << ", t side " << j;
}

}  // namespace
}  // namespace ccfr
