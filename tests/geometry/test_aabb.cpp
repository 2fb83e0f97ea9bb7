// all_apart against the test of every pair: random box sets at gaps around their spacing, boxes
// that sit exactly at the gap, flat and point boxes, empty sets, empty boxes and NaN.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "ccfr/geometry/aabb.hpp"

namespace ccfr {
namespace {

bool brute_all_apart(const std::vector<AABB>& a, const std::vector<AABB>& b, double gap) {
  for (const AABB& x : a)
    for (const AABB& y : b)
      if (!x.apart(y, gap)) return false;
  return true;
}

std::vector<AABB> random_boxes(std::mt19937& rng, int n, double spread, double size, double flat_share) {
  std::uniform_real_distribution<double> at(-spread, spread), extent(0.0, size), coin(0.0, 1.0);
  std::vector<AABB> out;
  for (int i = 0; i < n; ++i) {
    const Vec3 lo(at(rng), at(rng), at(rng));
    Vec3 hi = lo + Vec3(extent(rng), extent(rng), extent(rng));
    if (coin(rng) < flat_share) hi.y() = lo.y();  // a flat box (a triangle in a coordinate plane)
    if (coin(rng) < 0.5 * flat_share) hi = lo;    // a point
    out.push_back(AABB::of(lo, hi));
  }
  return out;
}

TEST(AllApart, MatchesEveryPairOnRandomSets) {
  std::mt19937 rng(7);
  std::vector<AABB> scratch;
  int apart = 0, meet = 0;
  for (int trial = 0; trial < 600; ++trial) {
    const int na = 1 + static_cast<int>(rng() % 60), nb = 1 + static_cast<int>(rng() % 60);
    const double spread = 0.05 + 0.01 * static_cast<double>(rng() % 20), size = 0.02;
    auto a = random_boxes(rng, na, spread, size, 0.2);
    auto b = random_boxes(rng, nb, spread, size, 0.2);
    // Half the trials move b away along a random axis so that both answers occur.
    if (trial % 2 == 1)
      for (AABB& x : b) {
        x.lo[trial % 3] += 2.0 * spread;
        x.hi[trial % 3] += 2.0 * spread;
      }
    for (const double gap : {0.0, 0.001, 0.01, 0.05}) {
      const bool expected = brute_all_apart(a, b, gap);
      EXPECT_EQ(all_apart(a, b, gap, scratch), expected) << "trial " << trial << " gap " << gap;
      EXPECT_EQ(all_apart(b, a, gap, scratch), expected) << "trial " << trial << " gap " << gap << " swapped";
      (expected ? apart : meet) += 1;
    }
  }
  EXPECT_GT(apart, 200);
  EXPECT_GT(meet, 200);
}

TEST(AllApart, BoxesExactlyAtTheGapMeet) {
  // apart() needs more than the gap on some axis: boxes exactly gap apart along x are not apart,
  // wherever the pair sits in the sorted order, and a hair more is.
  std::vector<AABB> scratch;
  const double gap = 0.004;
  std::vector<AABB> a, b;
  for (int i = 0; i < 20; ++i) {
    const double x = 0.1 * i;
    a.push_back(AABB::of(Vec3(x, 0, 0), Vec3(x + 0.01, 0.01, 0.01)));
    b.push_back(AABB::of(Vec3(x + 0.05, 0.5, 0), Vec3(x + 0.06, 0.51, 0.01)));
  }
  EXPECT_TRUE(all_apart(a, b, gap, scratch));
  const AABB touching = AABB::of(Vec3(1.0 + 0.01 + gap, 0, 0), Vec3(1.2, 0.01, 0.01));
  b.push_back(touching);  // about gap from a[10] along x: the pairwise test decides either way
  EXPECT_EQ(all_apart(a, b, gap, scratch), brute_all_apart(a, b, gap));
  b.back().lo.x() = std::nextafter(1.0 + 0.01 + gap, 2.0) + 1e-12;
  EXPECT_EQ(all_apart(a, b, gap, scratch), brute_all_apart(a, b, gap));
  // A box wider than any other, starting far before the one it meets (the window's widest term).
  b.push_back(AABB::of(Vec3(-5.0, 0.0, 0.0), Vec3(0.0, 0.01, 0.01)));
  EXPECT_FALSE(brute_all_apart(a, b, gap));
  EXPECT_FALSE(all_apart(a, b, gap, scratch));
}

TEST(AllApart, DegenerateSets) {
  std::vector<AABB> scratch;
  const std::vector<AABB> none;
  const std::vector<AABB> one{AABB::of(Vec3::Zero())};
  EXPECT_TRUE(all_apart(none, one, 0.01, scratch));
  EXPECT_TRUE(all_apart(one, none, 0.01, scratch));
  // Coincident points meet at any gap >= 0; an empty box (AABB{}) is apart from everything.
  EXPECT_FALSE(all_apart(one, one, 0.0, scratch));
  const std::vector<AABB> empty_box{AABB{}};
  EXPECT_TRUE(all_apart(empty_box, one, 1.0, scratch));
  EXPECT_EQ(all_apart(empty_box, one, 1.0, scratch), brute_all_apart(empty_box, one, 1.0));
  // A NaN box meets everything, as apart() answers for it.
  const double nan = std::numeric_limits<double>::quiet_NaN();
  std::vector<AABB> with_nan{AABB::of(Vec3(10, 10, 10)), AABB::of(Vec3(nan, 0, 0))};
  EXPECT_FALSE(brute_all_apart(with_nan, one, 0.01));
  EXPECT_FALSE(all_apart(with_nan, one, 0.01, scratch));
  EXPECT_FALSE(all_apart(one, with_nan, 0.01, scratch));
}

}  // namespace
}  // namespace ccfr
