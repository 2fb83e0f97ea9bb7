// The exact projection for many planes (dual active-set path of exact_region_projection, used
// above 24 planes) against the independent brute-force reference.
#include <gtest/gtest.h>

#include "ccfr/feasibility/exact_projector.hpp"
#include "random_regions.hpp"
#include "test_support.hpp"

using namespace ccfr;

TEST(ExactManyPlanes, MatchesTheBruteForceReference) {
  auto g = ccfr::test::rng(2026);
  double worst = 0.0;
  int compared = 0;
  for (int trial = 0; trial < 120; ++trial) {
    const int m = 25 + trial % 16;  // above the enumeration limit
    const auto pr = ccfr::test::random_problem(g, m);
    const Vec3 q = pr.candidate - pr.anchor;
    Vec3 ref;
    if (!ccfr::test::reference_projection(q, pr.planes, 1e-12, ref)) continue;
    const ExactProjection e = exact_region_projection(q, pr.planes, 0.0, 1e-13);
    ASSERT_TRUE(e.found) << "trial " << trial;
    worst = std::max(worst, (e.p - ref).norm());
    ++compared;
    for (const auto& h : pr.planes) EXPECT_GE(h.n.dot(e.p) + h.d, -1e-12);
  }
  EXPECT_GT(compared, 100);
  EXPECT_LT(worst, 1e-10);
}

TEST(ExactManyPlanes, HundredsOfPlanesWithAnInfeasibleAnchor) {
  // d < 0 for some planes (clarification 7): still the projection onto the region, which here
  // is a small box around a point at distance 0.003 from the anchor.
  auto g = ccfr::test::rng(11);
  std::vector<HalfSpace> planes;
  const Vec3 c(0.003, 0.0, 0.0);
  for (int k = 0; k < 300; ++k) {
    HalfSpace h;
    h.n = ccfr::test::random_unit(g);
    h.d = 0.001 - h.n.dot(c);  // n.(p - c) + 0.001 >= 0: every plane passes 1 mm from c
    planes.push_back(h);
  }
  const Vec3 q(0.05, 0.02, -0.01);
  const ExactProjection e = exact_region_projection(q, planes, 0.0, 1e-13);
  ASSERT_TRUE(e.found);
  for (const auto& h : planes) EXPECT_GE(h.n.dot(e.p) + h.d, -1e-12);
  // Optimality: no sampled feasible point is closer to q (the region is within 1 mm of c).
  std::uniform_real_distribution<double> u(-0.0012, 0.0012);
  for (int s = 0; s < 20000; ++s) {
    const Vec3 y = c + Vec3(u(g), u(g), u(g));
    bool ok = true;
    for (const auto& h : planes) ok = ok && h.n.dot(y) + h.d >= 0.0;
    if (ok) EXPECT_GE((y - q).norm(), (e.p - q).norm() - 1e-12);
  }
}

TEST(ExactManyPlanes, EmptyRegionIsReported) {
  std::vector<HalfSpace> planes;
  for (int k = 0; k < 30; ++k) {
    HalfSpace a, b;
    a.n = Vec3::UnitX();
    a.d = -0.01;  // x >= 0.01
    b.n = -Vec3::UnitX();
    b.d = 0.0;  // x <= 0
    planes.push_back(a);
    planes.push_back(b);
  }
  EXPECT_FALSE(exact_region_projection(Vec3(0.5, 0, 0), planes, 0.0, 1e-13).found);
}
