// What the projectors return must be what they claim: Plesník never lands farther from the
// candidate than the anchor (it falls back to the exact projection and says so), and an empty
// region is rejected by a certificate in microseconds, agreeing with the brute-force reference
// on seeded random regions of mixed scales and with d < 0.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <random>

#include "ccfr/feasibility/exact_projector.hpp"
#include "ccfr/feasibility/plesnik.hpp"
#include "random_regions.hpp"
#include "test_support.hpp"

namespace ccfr {
namespace {

// The anchor is a feasible point at |q| from the candidate: a projector returning a feasible
// point farther than that has not projected. Before the fallback this failed in ~0.7 % of cases.
TEST(PlesnikFallback, NeverFartherFromTheCandidateThanTheAnchor) {
  const PlesnikProjector plesnik;
  const ExactProjector exact;
  auto g = test::rng(31337);
  int violated = 0, fallbacks = 0, matched = 0, projected = 0;
  for (int trial = 0; trial < 20000; ++trial) {
    const auto prob = test::random_problem(g, 1 + trial % 16);
    const auto r = plesnik.project(prob.anchor, prob.candidate, prob.planes);
    if (r.status == ProjectStatus::feasible) continue;
    ++violated;
    const double to_anchor = (prob.anchor - prob.candidate).norm();
    EXPECT_LE((r.x - prob.candidate).norm(), to_anchor * (1 + 1e-15)) << "trial " << trial;
    EXPECT_GE(min_value(prob.anchor, r.x, prob.planes), -1e-12) << "trial " << trial;
    if (r.status == ProjectStatus::projected) ++projected;
    if (!r.fell_back) {
      // Plesník's own point, when kept, agrees with the exact projection (p50/p90 rounding level).
      const auto e = exact.project(prob.anchor, prob.candidate, prob.planes);
      matched += (r.x - e.x).norm() <= 1e-9;
      continue;
    }
    ++fallbacks;
    const auto e = exact.project(prob.anchor, prob.candidate, prob.planes);
    ASSERT_EQ(e.status, ProjectStatus::projected);
    EXPECT_EQ(r.x, e.x) << "a fallback returns the exact projector's answer";
    EXPECT_EQ(r.status, ProjectStatus::projected);
  }
  std::printf(
      "[plesnik fallback] violated %d, fell back %d (%.2f%%), projected %d, of which kept and equal to the "
      "exact projection %d (%.1f%% of the violated)\n",
      violated, fallbacks, 100.0 * fallbacks / violated, projected, matched, 100.0 * matched / violated);
  EXPECT_GT(fallbacks, 0);              // the case exists and is detected
  EXPECT_LT(fallbacks, violated / 50);  // and stays rare
}

TEST(PlesnikFallback, ProjectAllCountsTheFallbacks) {
  auto g = test::rng(31337);
  const Index n = 4000;
  std::vector<std::vector<TaggedHalfSpace>> buffers(1);
  Positions anchor(n), x(n);
  for (Index v = 0; v < n; ++v) {
    const auto prob = test::random_problem(g, 1 + static_cast<int>(v % 16));
    anchor[static_cast<size_t>(v)] = prob.anchor;
    x[static_cast<size_t>(v)] = prob.candidate;
    for (size_t k = 0; k < prob.planes.size(); ++k) buffers[0].push_back({v, k, prob.planes[k]});
  }
  RegionSet regions;
  build_region_set(n, buffers, regions);
  const PlesnikProjector plesnik;
  Index expected = 0;
  for (Index v = 0; v < n; ++v)
    expected += plesnik.project(anchor[static_cast<size_t>(v)], x[static_cast<size_t>(v)], regions.of(v)).fell_back;
  const BatchStats s = project_all(plesnik, regions, anchor, x, {});
  EXPECT_EQ(s.fallbacks, expected);
  EXPECT_GT(s.fallbacks, 0);
}

/// Random region with mixed scales: |d| = 10^U(-9, 0), a third of the offsets negative (anchor
/// outside, clarification 7), normals on the sphere or in a cone; the candidate within 1 of the anchor.
test::RandomProblem mixed_scale_problem(std::mt19937_64& g, int count) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  test::RandomProblem p;
  p.anchor = Vec3(u(g), u(g), u(g));
  const bool clustered = u(g) < 0.5;
  const Vec3 axis = test::random_unit(g);
  for (int k = 0; k < count; ++k) {
    HalfSpace h;
    h.n = clustered ? test::random_in_cone(g, axis, M_PI / 3) : test::random_unit(g);
    h.d = std::pow(10.0, -9.0 * u(g)) * (u(g) < 1.0 / 3.0 ? -1.0 : 1.0);
    p.planes.push_back(h);
  }
  p.candidate = p.anchor + std::pow(10.0, -6.0 * u(g)) * test::random_unit(g);
  return p;
}

TEST(ExactEmptyRegion, AgreesWithTheReferenceAndRejectsInMicroseconds) {
  ProjectorParams params;
  params.epsilon = 0.0;  // the plain projection, comparable with the reference
  const ExactProjector exact(params);
  auto g = test::rng(99);
  int empty = 0, nonempty = 0, borderline = 0;
  double worst = 0.0, empty_seconds = 0.0;
  for (int trial = 0; trial < 3000; ++trial) {
    const auto prob = mixed_scale_problem(g, 2 + trial % 11);
    const Vec3 q = prob.candidate - prob.anchor;
    Vec3 ref, ref_loose;
    const bool ref_found = test::reference_projection(q, prob.planes, 1e-13, ref);
    // Regions that are empty or not depending on a 1e-9 slack are left out: either answer is right.
    if (ref_found != test::reference_projection(q, prob.planes, 1e-9, ref_loose)) {
      ++borderline;
      continue;
    }
    const auto t0 = std::chrono::steady_clock::now();
    const auto r = exact.project(prob.anchor, prob.candidate, prob.planes);
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (!ref_found) {
      ++empty;
      empty_seconds += seconds;
      EXPECT_EQ(r.status, ProjectStatus::infeasible) << "trial " << trial;
      EXPECT_EQ(r.x, prob.anchor) << "trial " << trial;
      continue;
    }
    if (r.status == ProjectStatus::feasible) continue;
    ++nonempty;
    ASSERT_EQ(r.status, ProjectStatus::projected) << "trial " << trial;
    const double err = (r.x - (prob.anchor + ref)).norm();
    worst = std::max(worst, err);
    EXPECT_LT(err, 1e-9) << "trial " << trial;
  }
  const double mean_us = 1e6 * empty_seconds / std::max(empty, 1);
  std::printf(
      "[exact, mixed scales] empty %d (mean rejection %.2f us), projected %d (worst deviation %.2e), "
      "borderline skipped %d\n",
      empty, mean_us, nonempty, worst, borderline);
  EXPECT_GT(empty, 300);
  EXPECT_GT(nonempty, 300);
  // Before the certificate an empty region with <= 24 planes ran 20,000 Hildreth sweeps: 5-6.5 ms.
  EXPECT_LT(mean_us, 200.0);
}

// Up to the enumeration limit (24 planes): a box and its mirror image, a point region and slabs.
TEST(ExactEmptyRegion, StructuredEmptyRegionsAreRejected) {
  const Vec3 x = Vec3::UnitX(), y = Vec3::UnitY(), z = Vec3::UnitZ();
  const std::vector<std::vector<HalfSpace>> empty = {
      {{x, -1e-9}, {-x, 0.0}},                                      // x >= 1e-9 and x <= 0
      {{x, -0.5}, {y, -0.5}, {Vec3(-1, -1, 0).normalized(), 0.1}},  // a wedge cut off
      {{x, 0.0}, {y, 0.0}, {z, 0.0}, {Vec3(-1, -1, -1).normalized(), -1e-6}},
  };
  for (const auto& planes : empty) {
    std::vector<HalfSpace> many = planes;
    while (many.size() < 24) many.push_back(planes[many.size() % planes.size()]);  // duplicates
    for (const std::vector<HalfSpace>* set : std::initializer_list<const std::vector<HalfSpace>*>{&planes, &many}) {
      const ExactProjection e = exact_region_projection(Vec3(0.3, -0.2, 0.1), *set, 0.0, 1e-13);
      EXPECT_FALSE(e.found);
      const auto r = ExactProjector().project(Vec3::Zero(), Vec3(0.3, -0.2, 0.1), *set);
      EXPECT_EQ(r.status, ProjectStatus::infeasible);
    }
  }
  // The region {0} itself (three pairs of opposing planes through the anchor) is not empty.
  const std::vector<HalfSpace> point = {{x, 0}, {-x, 0}, {y, 0}, {-y, 0}, {z, 0}, {-z, 0}};
  const ExactProjection e = exact_region_projection(Vec3(0.3, -0.2, 0.1), point, 0.0, 1e-13);
  ASSERT_TRUE(e.found);
  EXPECT_LT(e.p.norm(), 1e-15);
}

}  // namespace
}  // namespace ccfr
