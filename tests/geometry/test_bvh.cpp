// The flat BVH against brute force: identical pair sets on random soups and cloth-like grids,
// before and after refit; box queries; determinism; NaN guard.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <set>

#include "ccfr/core/error.hpp"
#include "ccfr/core/parallel.hpp"
#include "ccfr/geometry/bvh.hpp"
#include "test_support.hpp"

namespace ccfr {
namespace {

using Pairs = std::vector<std::pair<Index, Index>>;

Pairs brute_pairs(const std::vector<AABB>& boxes) {
  Pairs p;
  for (Index i = 0; i < static_cast<Index>(boxes.size()); ++i)
    for (Index j = i + 1; j < static_cast<Index>(boxes.size()); ++j)
      if (boxes[i].overlaps(boxes[j])) p.emplace_back(i, j);
  return p;
}

Pairs sorted(Pairs p) {
  std::sort(p.begin(), p.end());
  return p;
}

std::vector<AABB> random_soup(std::mt19937_64& g, int n, double size) {
  std::uniform_real_distribution<double> u(0, 1), s(0, size);
  std::vector<AABB> boxes(n);
  for (auto& b : boxes) {
    const Vec3 c(u(g), u(g), u(g));
    b = AABB::of(c, c + Vec3(s(g), s(g), s(g)));
  }
  return boxes;
}

// Triangle boxes of a res x res grid on [0,1]^2 displaced by sines, grown by `margin`.
std::vector<AABB> cloth_boxes(int res, double phase, double margin) {
  auto at = [&](int i, int j) {
    const double x = double(i) / res, z = double(j) / res;
    return Vec3(x, 0.05 * std::sin(12 * x + phase) * std::cos(9 * z - phase), z);
  };
  std::vector<AABB> boxes;
  for (int i = 0; i < res; ++i)
    for (int j = 0; j < res; ++j) {
      AABB a = AABB::of(at(i, j), at(i + 1, j), at(i + 1, j + 1));
      AABB b = AABB::of(at(i, j), at(i + 1, j + 1), at(i, j + 1));
      a.inflate(margin);
      b.inflate(margin);
      boxes.push_back(a);
      boxes.push_back(b);
    }
  return boxes;
}

TEST(Bvh, RandomSoupMatchesBruteForce) {
  auto g = test::rng(11);
  for (int leaf : {1, 2, 4, 8}) {
    for (int n : {0, 1, 2, 3, 17, 500, 2000}) {
      auto boxes = random_soup(g, n, 0.08);
      Bvh bvh;
      bvh.build(boxes, leaf);
      EXPECT_EQ(bvh.size(), n);
      Pairs p;
      bvh.self_pairs(p);
      for (auto [i, j] : p) EXPECT_LT(i, j);
      EXPECT_EQ(sorted(p), brute_pairs(boxes)) << "n=" << n << " leaf=" << leaf;
      const std::set<std::pair<Index, Index>> unique(p.begin(), p.end());
      EXPECT_EQ(unique.size(), p.size());  // no duplicates
      // Refit to moved boxes keeps correctness.
      auto moved = random_soup(g, n, 0.12);
      bvh.refit(moved);
      bvh.self_pairs(p);
      EXPECT_EQ(sorted(p), brute_pairs(moved));
    }
  }
}

TEST(Bvh, OneOutputVectorServesQueriesOfEveryCount) {
  // The output keeps its elements between queries (only a growth is initialised): a query with
  // fewer pairs than the last, or none, must leave exactly its own pairs, and one past the
  // vector's capacity exactly its own too.
  auto g = test::rng(5);
  Pairs p;
  for (const auto& [n, size] : std::vector<std::pair<int, double>>{
           {2000, 0.12}, {300, 0.05}, {0, 0.1}, {1, 0.1}, {2000, 0.03}, {3000, 0.15}, {50, 0.2}}) {
    const auto boxes = random_soup(g, n, size);
    Bvh bvh;
    bvh.build(boxes, 4);
    bvh.self_pairs(p);
    EXPECT_EQ(sorted(p), brute_pairs(boxes)) << "n=" << n << " size=" << size;
  }
}

TEST(Bvh, ClothGridMatchesBruteForceAfterRefit) {
  auto boxes = cloth_boxes(24, 0.0, 0.01);
  Bvh bvh;
  bvh.build(boxes, 4);
  Pairs p;
  bvh.self_pairs(p);
  EXPECT_EQ(sorted(p), brute_pairs(boxes));
  for (double phase : {0.7, 2.1}) {
    auto moved = cloth_boxes(24, phase, 0.02);
    bvh.refit(moved);
    bvh.self_pairs(p);
    EXPECT_EQ(sorted(p), brute_pairs(moved));
  }
}

TEST(Bvh, DegenerateBoxes) {
  // Identical boxes, points (zero extent), touching boxes and empty boxes.
  std::vector<AABB> boxes;
  for (int i = 0; i < 20; ++i) boxes.push_back(AABB::of(Vec3(0, 0, 0), Vec3(1, 1, 1)));
  for (int i = 0; i < 10; ++i) boxes.push_back(AABB::of(Vec3(2, 0, 0)));
  boxes.push_back(AABB::of(Vec3(1, 1, 1), Vec3(2, 2, 2)));  // touches the unit boxes at a corner
  boxes.push_back(AABB{});                                  // empty
  boxes.push_back(AABB{});
  Bvh bvh;
  bvh.build(boxes, 4);
  Pairs p;
  bvh.self_pairs(p);
  EXPECT_EQ(sorted(p), brute_pairs(boxes));
}

// Pairs inside one group or of two fixed boxes are never reported, every other overlapping pair
// is. Reference: the brute-force pair set, filtered afterwards. Groups are laid out both as
// clustered blocks (whole subtrees of one group: the pruned case) and scattered at random.
TEST(Bvh, GroupsAndFixedFlagsMatchFilteredBruteForce) {
  auto g = test::rng(21);
  for (int leaf : {1, 4}) {
    for (int n : {0, 1, 2, 5, 300, 2000}) {
      for (int layout = 0; layout < 4; ++layout) {
        auto boxes = random_soup(g, n, 0.1);
        // Degenerate boxes: a run of coincident boxes and zero-size boxes at one point.
        for (int k = 0; k < n / 10; ++k)
          boxes[static_cast<size_t>(k)] = AABB::of(Vec3(0.5, 0.5, 0.5), Vec3(0.6, 0.6, 0.6));
        for (int k = n / 10; k < n / 5; ++k) boxes[static_cast<size_t>(k)] = AABB::of(Vec3(0.55, 0.55, 0.55));
        std::vector<std::uint32_t> groups(static_cast<size_t>(n), 0);
        std::vector<std::uint8_t> fixed(static_cast<size_t>(n), 0);
        for (int i = 0; i < n; ++i) {
          // 0: one group for all; 1: blocks of 100 by index, a third ungrouped; 2: random of 4; 3: random + fixed.
          groups[i] = layout == 0   ? 7u
                      : layout == 1 ? ((i / 100) % 3 == 0 ? 0u : static_cast<std::uint32_t>(i / 100) + 1)
                                    : static_cast<std::uint32_t>(g() % 5);
          fixed[i] = layout == 3 ? static_cast<std::uint8_t>(g() % 3 == 0) : 0;
        }
        Bvh bvh;
        bvh.build(boxes, leaf);
        for (int pass = 0; pass < 2; ++pass) {
          if (pass == 1) {
            boxes = random_soup(g, n, 0.15);
            bvh.refit(boxes);
          }
          Pairs want;
          for (auto [i, j] : brute_pairs(boxes))
            if (!(groups[i] != 0 && groups[i] == groups[j]) && !(fixed[i] && fixed[j])) want.emplace_back(i, j);
          Pairs p;
          bvh.self_pairs(p, layout == 3 ? std::span<const std::uint8_t>(fixed) : std::span<const std::uint8_t>{},
                         groups);
          EXPECT_EQ(sorted(p), want) << "n=" << n << " leaf=" << leaf << " layout=" << layout << " pass=" << pass;
          const std::set<std::pair<Index, Index>> unique(p.begin(), p.end());
          EXPECT_EQ(unique.size(), p.size());
          if (layout == 0) EXPECT_TRUE(p.empty());
          // Without groups, every pair again.
          bvh.self_pairs(p, {}, {});
          EXPECT_EQ(sorted(p), brute_pairs(boxes));
        }
      }
    }
  }
  std::vector<AABB> boxes(6, AABB::of(Vec3(0, 0, 0), Vec3(1, 1, 1)));
  Bvh bvh;
  bvh.build(boxes);
  Pairs p;
  EXPECT_THROW(bvh.self_pairs(p, {}, std::vector<std::uint32_t>(5, 1)), Error);
}

TEST(Bvh, QueryMatchesBruteForce) {
  auto g = test::rng(12);
  auto boxes = random_soup(g, 3000, 0.05);
  Bvh bvh;
  bvh.build(boxes);
  auto queries = random_soup(g, 200, 0.2);
  for (const AABB& q : queries) {
    std::vector<Index> got, want;
    bvh.query(q, got);
    for (Index i = 0; i < 3000; ++i)
      if (boxes[i].overlaps(q)) want.push_back(i);
    std::sort(got.begin(), got.end());
    EXPECT_EQ(got, want);
  }
  std::vector<Index> none;
  AABB nan_box = AABB::of(Vec3(std::nan(""), 0, 0), Vec3(1, 1, 1));
  bvh.query(nan_box, none);
  EXPECT_TRUE(none.empty());
}

TEST(Bvh, DeterministicAcrossThreadCounts) {
  auto boxes = cloth_boxes(40, 0.3, 0.01);
  Bvh bvh;
  bvh.build(boxes);
  Pairs p1, p2;
  set_thread_count(1);
  bvh.self_pairs(p1);
  set_thread_count(2);
  bvh.self_pairs(p2);
  set_thread_count(0);
  EXPECT_EQ(p1, p2);
}

TEST(Bvh, RejectsNaNBoxes) {
  std::vector<AABB> boxes(4, AABB::of(Vec3(0, 0, 0), Vec3(1, 1, 1)));
  boxes[2].hi.y() = std::numeric_limits<double>::quiet_NaN();
  Bvh bvh;
  EXPECT_THROW(bvh.build(boxes), Error);
  boxes[2].hi.y() = 1;
  bvh.build(boxes);
  boxes[3].lo.x() = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(bvh.refit(boxes), Error);
  boxes.pop_back();
  EXPECT_THROW(bvh.refit(boxes), Error);
}

TEST(Bvh, RefitOfManyBoxesInParallelMatchesAFreshBuildAndNamesTheFirstNaNUnchanged) {
  // 60,000 boxes: the refit's copy, NaN check and leaves run in many chunks. After moving every
  // box a little, the refitted tree finds the pairs of a tree built afresh over the moved boxes, at 1 and
  // 2 threads. A refit over boxes with NaN in several chunks names the lowest index and leaves the
  // tree as it was.
  auto g = test::rng(31);
  const Index n = 60000;
  auto boxes = random_soup(g, n, 0.02);
  Bvh bvh;
  bvh.build(boxes);
  std::uniform_real_distribution<double> step(-0.01, 0.01);
  for (AABB& b : boxes) {
    const Vec3 d(step(g), step(g), step(g));
    b = AABB::of(b.lo + d, b.hi + d);
  }
  Bvh fresh;
  fresh.build(boxes);
  Pairs want;
  fresh.self_pairs(want);
  ASSERT_GT(want.size(), 1000u);
  for (int threads : {1, 2}) {
    set_thread_count(threads);
    bvh.refit(boxes);
    Pairs got;
    bvh.self_pairs(got);
    EXPECT_EQ(sorted(got), sorted(want)) << threads << " threads";
  }
  auto bad = boxes;
  bad[51234].hi.z() = std::numeric_limits<double>::quiet_NaN();
  bad[17345].lo.x() = std::numeric_limits<double>::quiet_NaN();
  bad[40001].lo.y() = std::numeric_limits<double>::quiet_NaN();
  try {
    bvh.refit(bad);
    ADD_FAILURE() << "a NaN box was refitted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("box 17345 "), std::string::npos) << e.what();
  }
  Pairs after;
  bvh.self_pairs(after);
  EXPECT_EQ(sorted(after), sorted(want)) << "a failed refit changed the tree";
  set_thread_count(0);
}

}  // namespace
}  // namespace ccfr
