// Exact predicates on constructed cases (touching, coplanar, degenerate), and the double
// distance kernels of ccfr::geometry against CGAL's exact squared distances.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "ccfr/geometry/distance.hpp"
#include "ccfr/geometry_exact/predicates.hpp"
#include "test_support.hpp"

namespace ccfr::exact {
namespace {

Vec3 rand_vec(std::mt19937_64& g) {
  std::uniform_real_distribution<double> u(-1, 1);
  return Vec3(u(g), u(g), u(g));
}

TEST(Predicates, Orient3dSign) {
  const Vec3 a(0, 0, 0), b(1, 0, 0), c(0, 1, 0);
  EXPECT_EQ(orient3d(a, b, c, Vec3(0, 0, 1)), 1);  // along the normal (b - a) x (c - a) = +z
  EXPECT_EQ(orient3d(a, b, c, Vec3(0, 0, -1)), -1);
  EXPECT_EQ(orient3d(a, b, c, Vec3(3, 7, 0)), 0);
  // Exact on a nearly coplanar point that double evaluation would round to zero or the wrong sign.
  EXPECT_EQ(orient3d(a, b, c, Vec3(0.1, 0.1, 1e-300)), 1);
}

TEST(Predicates, TriangleTriangle) {
  const Vec3 a(0, 0, 0), b(1, 0, 0), c(0, 1, 0);
  // Crossing.
  EXPECT_TRUE(triangles_intersect(a, b, c, Vec3(0.2, 0.2, -1), Vec3(0.2, 0.2, 1), Vec3(0.3, 0.8, 0)));
  // Separated above.
  EXPECT_FALSE(triangles_intersect(a, b, c, Vec3(0, 0, 1e-12), Vec3(1, 0, 1e-12), Vec3(0, 1, 1e-12)));
  // Touching at a vertex (exactly on the face) counts.
  EXPECT_TRUE(triangles_intersect(a, b, c, Vec3(0.25, 0.25, 0), Vec3(0.5, 0.5, 1), Vec3(0, 0.5, 1)));
  // Touching edge to edge.
  EXPECT_TRUE(triangles_intersect(a, b, c, Vec3(0.5, 0.5, 0), Vec3(1, 1, 0), Vec3(1, 1, 1)));
  // Just off the edge by one ulp-ish amount.
  EXPECT_FALSE(triangles_intersect(a, b, c, Vec3(0.5, 0.5 + 1e-15, 0), Vec3(1, 1, 0), Vec3(1, 1, 1)));
  // Coplanar overlapping and coplanar disjoint.
  EXPECT_TRUE(triangles_intersect(a, b, c, Vec3(0.1, 0.1, 0), Vec3(2, 0.1, 0), Vec3(0.1, 2, 0)));
  EXPECT_FALSE(triangles_intersect(a, b, c, Vec3(1, 1, 0), Vec3(2, 1, 0), Vec3(1, 2, 0)));
  // Shared vertex (adjacent mesh triangles) intersect at that vertex.
  EXPECT_TRUE(triangles_intersect(a, b, c, b, Vec3(1, 1, 0), c));
}

TEST(Predicates, DegenerateTriangles) {
  const Vec3 a(0, 0, 0), b(1, 0, 0), c(0, 1, 0);
  // A collinear triangle (a segment) crossing the face, and one passing beside it.
  EXPECT_TRUE(triangles_intersect(a, b, c, Vec3(0.2, 0.2, -1), Vec3(0.2, 0.2, 1), Vec3(0.2, 0.2, 0.5)));
  EXPECT_FALSE(triangles_intersect(a, b, c, Vec3(2, 2, -1), Vec3(2, 2, 1), Vec3(2, 2, 0)));
  // The middle point listed first: the extreme points must be found.
  EXPECT_TRUE(triangles_intersect(a, b, c, Vec3(0.2, 0.2, 0.5), Vec3(0.2, 0.2, -1), Vec3(0.2, 0.2, 1)));
  // A triangle collapsed to a point on / off the face.
  EXPECT_TRUE(triangles_intersect(a, b, c, Vec3(0.2, 0.2, 0), Vec3(0.2, 0.2, 0), Vec3(0.2, 0.2, 0)));
  EXPECT_FALSE(triangles_intersect(a, b, c, Vec3(0.2, 0.2, 1e-9), Vec3(0.2, 0.2, 1e-9), Vec3(0.2, 0.2, 1e-9)));
  // Both degenerate: two crossing collinear "triangles".
  EXPECT_TRUE(
      triangles_intersect(Vec3(-1, 0, 0), Vec3(1, 0, 0), Vec3(0, 0, 0), Vec3(0, -1, 0), Vec3(0, 1, 0), Vec3(0, 1, 0)));
}

TEST(Predicates, SegmentTriangle) {
  const Vec3 a(0, 0, 0), b(1, 0, 0), c(0, 1, 0);
  EXPECT_TRUE(segment_triangle_intersect(Vec3(0.2, 0.2, -1), Vec3(0.2, 0.2, 1), a, b, c));
  EXPECT_FALSE(segment_triangle_intersect(Vec3(0.2, 0.2, 1e-15), Vec3(0.2, 0.2, 1), a, b, c));
  EXPECT_TRUE(segment_triangle_intersect(Vec3(0.2, 0.2, 0), Vec3(0.2, 0.2, 1), a, b, c));    // touching
  EXPECT_TRUE(segment_triangle_intersect(Vec3(-1, 0.5, 0), Vec3(2, 0.5, 0), a, b, c));       // coplanar
  EXPECT_FALSE(segment_triangle_intersect(Vec3(0.6, 0.6, -1), Vec3(0.6, 0.6, 1), a, b, c));  // beside edge
  EXPECT_TRUE(segment_triangle_intersect(Vec3(0.5, 0.5, -1), Vec3(0.5, 0.5, 1), a, b, c));   // through edge
  // Zero-length segment = point.
  EXPECT_TRUE(segment_triangle_intersect(Vec3(0.1, 0.1, 0), Vec3(0.1, 0.1, 0), a, b, c));
  EXPECT_FALSE(segment_triangle_intersect(Vec3(0.1, 0.1, 1), Vec3(0.1, 0.1, 1), a, b, c));
  EXPECT_TRUE(segments_intersect(Vec3(-1, 0, 0), Vec3(1, 0, 0), Vec3(0, -1, 0), Vec3(0, 1, 0)));
  EXPECT_FALSE(segments_intersect(Vec3(-1, 0, 0), Vec3(1, 0, 0), Vec3(0, -1, 1e-300), Vec3(0, 1, 1e-300)));
}

TEST(Predicates, DistanceComparisonsAtThreshold) {
  // Powers of two make the true squared distances exact doubles: the comparison must say 0.
  const Vec3 a(0, 0, 0), b(1, 0, 0), c(0, 1, 0);
  const double h = 0.125, h2 = h * h;
  const double above = std::nextafter(h2, 1.0), below = std::nextafter(h2, 0.0);
  const Vec3 p(0.25, 0.25, h);
  EXPECT_EQ(compare_point_triangle_distance_sq(p, a, b, c, h2), 0);
  EXPECT_EQ(compare_point_triangle_distance_sq(p, a, b, c, above), -1);
  EXPECT_EQ(compare_point_triangle_distance_sq(p, a, b, c, below), 1);
  EXPECT_EQ(compare_edge_edge_distance_sq(Vec3(-1, 0, 0), Vec3(1, 0, 0), Vec3(0, -1, h), Vec3(0, 1, h), h2), 0);
  EXPECT_EQ(compare_edge_edge_distance_sq(Vec3(-1, 0, 0), Vec3(1, 0, 0), Vec3(0, -1, h), Vec3(0, 1, h), above), -1);
  EXPECT_EQ(compare_edge_edge_distance_sq(Vec3(-1, 0, 0), Vec3(1, 0, 0), Vec3(0, -1, h), Vec3(0, 1, h), below), 1);
  // Parallel edges at distance h.
  EXPECT_EQ(compare_edge_edge_distance_sq(Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0.5, h, 0), Vec3(3, h, 0), h2), 0);
  EXPECT_EQ(compare_point_edge_distance_sq(Vec3(0.5, h, 0), a, b, h2), 0);
  EXPECT_EQ(compare_point_edge_distance_sq(Vec3(0.5, h, 0), a, b, below), 1);
  EXPECT_EQ(compare_point_point_distance_sq(Vec3(h, 0, 0), a, h2), 0);
  EXPECT_EQ(compare_point_point_distance_sq(Vec3(h, 0, 0), a, above), -1);
  // Degenerate primitives.
  EXPECT_EQ(compare_point_triangle_distance_sq(Vec3(0.5, h, 0), a, b, Vec3(0.5, 0, 0), h2), 0);
  EXPECT_EQ(compare_point_triangle_distance_sq(Vec3(0, h, 0), a, a, a, h2), 0);
  EXPECT_EQ(compare_edge_edge_distance_sq(a, a, Vec3(0, h, 0), Vec3(0, h, 0), h2), 0);
  EXPECT_EQ(compare_point_edge_distance_sq(Vec3(0, 0, h), a, a, below), 1);
}

// The double kernels of ccfr::geometry against CGAL's exact squared distances.
TEST(Predicates, DoubleKernelsMatchExactDistances) {
  auto g = test::rng(21);
  std::uniform_real_distribution<double> u(-1.5, 2.5);
  for (int i = 0; i < 3000; ++i) {
    const Vec3 p = rand_vec(g), a = rand_vec(g), b = rand_vec(g), c = rand_vec(g), d = rand_vec(g);
    const double tol = 1e-13;
    EXPECT_NEAR(point_edge(p, a, b).distance_sq, exact_point_edge_distance_sq(p, a, b), tol);
    EXPECT_NEAR(point_triangle(p, a, b, c).distance_sq, exact_point_triangle_distance_sq(p, a, b, c), tol);
    EXPECT_NEAR(edge_edge(a, b, c, d).distance_sq, exact_edge_edge_distance_sq(a, b, c, d), tol);
    // Degenerate: collinear / coincident triangles, parallel / collinear / zero-length edges.
    const Vec3 m = a + u(g) * (b - a);
    EXPECT_NEAR(point_triangle(p, a, b, m).distance_sq, exact_point_triangle_distance_sq(p, a, b, m), tol);
    EXPECT_NEAR(point_triangle(p, a, a, b).distance_sq, exact_point_triangle_distance_sq(p, a, a, b), tol);
    EXPECT_NEAR(point_triangle(p, a, a, a).distance_sq, exact_point_triangle_distance_sq(p, a, a, a), tol);
    const Vec3 off = 0.1 * rand_vec(g);
    const Vec3 q0 = a + u(g) * (b - a) + off, q1 = a + u(g) * (b - a) + off;
    EXPECT_NEAR(edge_edge(a, b, q0, q1).distance_sq, exact_edge_edge_distance_sq(a, b, q0, q1), tol);
    EXPECT_NEAR(edge_edge(a, b, q0 - off, q1 - off).distance_sq, exact_edge_edge_distance_sq(a, b, q0 - off, q1 - off),
                tol);
    EXPECT_NEAR(edge_edge(a, a, c, d).distance_sq, exact_edge_edge_distance_sq(a, a, c, d), tol);
    EXPECT_NEAR(edge_edge(a, a, c, c).distance_sq, exact_edge_edge_distance_sq(a, a, c, c), tol);
  }
}

// Nearly parallel edges (1e-12 .. 1e-3 rad) crossing in projection, side by side and collinear:
// the double kernel against CGAL's exact squared distance of the same (rounded) input. The former
// kernel (denominator a c - b^2) was off by up to 3e-2 in distance here.
TEST(Predicates, EdgeEdgeNearlyParallelMatchesExact) {
  auto g = test::rng(23);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (int e = -12; e <= -3; ++e) {
    const double angle = std::pow(10.0, e);
    for (int k = 0; k < 60; ++k) {
      const Vec3 dir = rand_vec(g).normalized(), side = dir.unitOrthogonal(), up = dir.cross(side);
      const Vec3 dir_b = std::cos(angle) * dir + std::sin(angle) * side;
      const double gap = std::pow(10.0, -4.0 * u(g));
      const Vec3 a0 = rand_vec(g), a1 = a0 + dir;
      Vec3 b0;
      switch (k % 3) {
        case 0:
          b0 = a0 + 0.5 * dir + gap * up + angle * (u(g) - 0.5) * side - (0.1 + 0.8 * u(g)) * dir_b;
          break;
        case 1:
          b0 = a0 + gap * up + (u(g) - 0.5) * dir;
          break;
        default:
          b0 = a1 + gap * dir;
          break;
      }
      const Vec3 b1 = b0 + dir_b;
      const double d = std::sqrt(edge_edge(a0, a1, b0, b1).distance_sq);
      const double exact = std::sqrt(exact_edge_edge_distance_sq(a0, a1, b0, b1));
      EXPECT_NEAR(d, exact, 1e-15) << "angle " << angle << " case " << k % 3;
    }
  }
}

// The filtered comparisons agree with the exact distance on both sides of a tight threshold.
TEST(Predicates, FilteredComparisonsAgreeWithExact) {
  auto g = test::rng(22);
  for (int i = 0; i < 500; ++i) {
    const Vec3 p = rand_vec(g), a = rand_vec(g), b = rand_vec(g), c = rand_vec(g), d = rand_vec(g);
    const double pt = exact_point_triangle_distance_sq(p, a, b, c);
    const double ee = exact_edge_edge_distance_sq(a, b, c, d);
    for (double f : {1 - 1e-6, 1 + 1e-6, 0.5, 2.0}) {
      EXPECT_EQ(compare_point_triangle_distance_sq(p, a, b, c, pt * f), f < 1 ? 1 : -1);
      if (ee > 0) EXPECT_EQ(compare_edge_edge_distance_sq(a, b, c, d, ee * f), f < 1 ? 1 : -1);
    }
  }
}

}  // namespace
}  // namespace ccfr::exact
