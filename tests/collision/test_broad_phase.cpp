// Every broad phase against the brute-force reference: identical pair sets on random soups,
// flat and folded cloth, strand bundles and mixed scenes, at build and after refits.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "ccfr/collision/broad_phase.hpp"
#include "ccfr/collision/broad_phase/brute_force.hpp"
#include "ccfr/collision/collision_detector.hpp"
#include "ccfr/collision/primitives.hpp"
#include "ccfr/core/error.hpp"
#include "scenes.hpp"
#include "test_support.hpp"

namespace ccfr {
namespace {

std::vector<IndexPair> sorted_pairs(BroadPhase& bp) {
  std::vector<IndexPair> out;
  bp.query_pairs(out);
  for (const auto& [i, j] : out) EXPECT_LT(i, j);
  std::sort(out.begin(), out.end());
  return out;
}

std::vector<IndexPair> reference_pairs(std::span<const AABB> boxes) {
  BruteForceBroadPhase ref;
  ref.build(boxes);
  return sorted_pairs(ref);
}

void expect_same_pairs(const std::string& name, std::span<const AABB> boxes, const std::string& what) {
  auto bp = make_broad_phase(name);
  bp->build(boxes);
  const auto expected = reference_pairs(boxes);
  const auto got = sorted_pairs(*bp);
  EXPECT_EQ(got, expected) << name << " on " << what;
  EXPECT_TRUE(std::adjacent_find(got.begin(), got.end()) == got.end()) << name << ": duplicate pairs";
}

std::vector<AABB> random_soup(std::uint64_t seed, Index n, double max_extent) {
  auto g = test::rng(seed);
  std::uniform_real_distribution<double> pos(0.0, 1.0), ext(0.0, max_extent);
  std::vector<AABB> boxes;
  for (Index i = 0; i < n; ++i) {
    AABB b = AABB::of(Vec3(pos(g), pos(g), pos(g)));
    b.hi += Vec3(ext(g), ext(g), ext(g));
    boxes.push_back(b);
  }
  return boxes;
}

std::vector<AABB> scene_boxes(const test::TestScene& s, const Positions& x) {
  const CollisionPrimitives prims = build_collision_primitives(s.topo);
  std::vector<AABB> boxes;
  compute_primitive_boxes(prims, s.topo, x, box_inflation(0.005, 0.01, 0.0005), boxes);
  return boxes;
}

test::TestScene mixed_scene() {
  gen::TriMesh cloth = test::accordion_cloth(0.3, 24, 1, 0.012, 0.003);
  gen::TriMesh sphere = gen::sphere(0.1, 2);
  for (auto& p : sphere.v) p += Vec3(0, -0.13, 0);
  gen::PolylineSet hair = gen::curly_strands(9, 20, 0.2, 0.04, 0.01, 2.0);
  for (auto& p : hair.v) p += Vec3(0.05, 0.25, 0);
  Positions dust = gen::particle_block(5, 3, 5, 0.012);
  for (auto& p : dust) p += Vec3(-0.05, 0.06, 0.02);
  gen::TetMesh jelly = gen::tet_box(Vec3(0.06, 0.06, 0.06), Vec3i(3, 3, 3));
  for (auto& p : jelly.v) p += Vec3(0.1, 0.07, -0.05);
  gen::TriMesh crate = gen::box(Vec3(0.05, 0.05, 0.05));
  for (auto& p : crate.v) p += Vec3(-0.1, 0.05, -0.08);
  return test::SceneBuilder()
      .mesh("cloth", ObjectKind::cloth, cloth)
      .mesh("ball", ObjectKind::obstacle, sphere, 0.0)
      .strands("hair", hair)
      .particles("dust", dust)
      .tets("jelly", jelly)
      .mesh("crate", ObjectKind::rigid, crate)
      .finish();
}

void perturb_boxes(std::vector<AABB>& boxes, std::uint64_t seed) {
  auto g = test::rng(seed);
  for (auto& b : boxes) {
    const Vec3 d = test::random_in_ball(g, 0.03);
    b.lo += d;
    b.hi += d;
  }
}

void perturb(Positions& x, std::uint64_t seed, double r) {
  auto g = test::rng(seed);
  for (auto& p : x) p += test::random_in_ball(g, r);
}

class EveryBroadPhase : public ::testing::TestWithParam<std::string> {};

TEST_P(EveryBroadPhase, RandomSoupsMatchBruteForce) {
  for (std::uint64_t seed = 1; seed <= 4; ++seed) {
    expect_same_pairs(GetParam(), random_soup(seed, 1500, 0.05 * static_cast<double>(seed)), "random soup");
  }
  // Degenerate boxes: points, coincident boxes, boxes that touch exactly (closed intervals).
  std::vector<AABB> touching;
  for (int i = 0; i < 50; ++i) touching.push_back(AABB::of(Vec3(i, 0, 0), Vec3(i + 1, 1, 1)));
  for (int i = 0; i < 20; ++i) touching.push_back(AABB::of(Vec3(3, 0.5, 0.5)));
  expect_same_pairs(GetParam(), touching, "touching boxes");
}

TEST_P(EveryBroadPhase, ScenesMatchBruteForceAfterRefits) {
  const std::vector<std::pair<std::string, test::TestScene>> scenes = [] {
    std::vector<std::pair<std::string, test::TestScene>> v;
    v.emplace_back("flat cloth",
                   test::SceneBuilder().mesh("c", ObjectKind::cloth, gen::grid(0.5, 0.5, 40, 40)).finish());
    v.emplace_back(
        "folded cloth",
        test::SceneBuilder().mesh("c", ObjectKind::cloth, test::accordion_cloth(0.5, 40, 3, 0.012, 0.004)).finish());
    v.emplace_back("strand bundle",
                   test::SceneBuilder().strands("s", gen::curly_strands(36, 30, 0.3, 0.06, 0.01, 3.0)).finish());
    v.emplace_back("mixed", mixed_scene());
    return v;
  }();
  for (const auto& [what, scene] : scenes) {
    auto bp = make_broad_phase(GetParam());
    Positions x = scene.x;
    std::vector<AABB> boxes = scene_boxes(scene, x);
    bp->build(boxes);
    EXPECT_EQ(sorted_pairs(*bp), reference_pairs(boxes)) << GetParam() << " on " << what << " at build";
    // Refits: small motions, then a large one that stretches the tree's boxes.
    for (int pass = 0; pass < 3; ++pass) {
      perturb(x, 100 + pass, pass == 2 ? 0.05 : 0.004);
      boxes = scene_boxes(scene, x);
      bp->update(boxes);
      EXPECT_EQ(sorted_pairs(*bp), reference_pairs(boxes)) << GetParam() << " on " << what << " after refit " << pass;
    }
  }
}

// Pairs of two fixed boxes are never reported; every other overlapping pair is. Reference: the
// brute-force pair set without fixed flags, filtered afterwards.
TEST_P(EveryBroadPhase, FixedPairsAreNeverReported) {
  for (std::uint64_t seed = 1; seed <= 3; ++seed) {
    const std::vector<AABB> boxes = random_soup(seed, 1200, 0.08);
    auto g = test::rng(seed + 50);
    std::vector<std::uint8_t> fixed(boxes.size());
    // Seed 1: every box fixed (nothing reported); 2: a random half; 3: one box free.
    for (size_t i = 0; i < fixed.size(); ++i) fixed[i] = seed == 1 ? 1 : (seed == 2 ? (g() & 1) : (i != 37));
    std::vector<IndexPair> expected;
    for (const auto& [i, j] : reference_pairs(boxes))
      if (!(fixed[i] && fixed[j])) expected.emplace_back(i, j);
    auto bp = make_broad_phase(GetParam());
    bp->build(boxes);
    bp->set_fixed(fixed);
    EXPECT_EQ(sorted_pairs(*bp), expected) << GetParam() << ", seed " << seed;
    if (seed == 1) EXPECT_TRUE(expected.empty());
    if (seed == 3) EXPECT_FALSE(expected.empty());
    bp->set_fixed({});  // cleared: every pair again
    EXPECT_EQ(sorted_pairs(*bp), reference_pairs(boxes)) << GetParam();
    bp->set_fixed(std::vector<std::uint8_t>(boxes.size() + 1, 0));
    EXPECT_THROW(sorted_pairs(*bp), Error) << GetParam() << ": flag count differs from the box count";
  }
}

// Pairs inside one nonzero group, or of two fixed boxes, are never reported; every other
// overlapping pair is, in every broad phase. Reference: the brute-force pair set without groups or
// flags, filtered afterwards. Boxes include coincident and zero-size ones; groups are clustered
// (subtrees of one group) or scattered; flags and groups change between queries and refits.
TEST_P(EveryBroadPhase, GroupPairsAreNeverReported) {
  for (std::uint64_t seed = 1; seed <= 4; ++seed) {
    std::vector<AABB> boxes = random_soup(seed, 1000, 0.08);
    for (size_t k = 0; k < 60; ++k) boxes[k] = AABB::of(Vec3(0.4, 0.4, 0.4), Vec3(0.5, 0.5, 0.5));  // coincident
    for (size_t k = 60; k < 100; ++k) boxes[k] = AABB::of(Vec3(0.45, 0.45, 0.45));  // zero-size, inside them
    auto g = test::rng(seed + 70);
    std::vector<std::uint32_t> groups(boxes.size());
    std::vector<std::uint8_t> fixed(boxes.size(), 0);
    for (size_t i = 0; i < boxes.size(); ++i) {
      // Seed 1: one group for all (nothing reported); 2: blocks by index, some ungrouped; 3: random
      // groups; 4: random groups and random fixed flags.
      groups[i] = seed == 1   ? 3u
                  : seed == 2 ? ((i / 80) % 4 == 0 ? 0u : static_cast<std::uint32_t>(i / 80))
                              : static_cast<std::uint32_t>(g() % 6);
      if (seed == 4) fixed[i] = g() % 3 == 0;
    }
    auto bp = make_broad_phase(GetParam());
    bp->set_groups(groups);  // before build: kept for it
    bp->build(boxes);
    for (int pass = 0; pass < 3; ++pass) {
      if (pass == 1) {
        perturb_boxes(boxes, seed + 5);
        bp->update(boxes);
      }
      if (pass == 2) {  // new groups after build: a tree partitioned by group must follow
        for (auto& id : groups) id = id == 2 ? 0u : id + 1;
        bp->set_groups(groups);
      }
      if (seed == 4) bp->set_fixed(fixed);
      std::vector<IndexPair> expected;
      for (const auto& [i, j] : reference_pairs(boxes))
        if (!(groups[i] != 0 && groups[i] == groups[j]) && !(fixed[i] && fixed[j])) expected.emplace_back(i, j);
      const auto got = sorted_pairs(*bp);
      EXPECT_EQ(got, expected) << GetParam() << ", seed " << seed << ", pass " << pass;
      EXPECT_TRUE(std::adjacent_find(got.begin(), got.end()) == got.end()) << GetParam() << ": duplicate pairs";
      if (seed == 1 && pass < 2) EXPECT_TRUE(expected.empty());
      if (seed > 1) EXPECT_FALSE(expected.empty());
    }
    bp->set_groups({});  // cleared: every pair again
    bp->set_fixed({});
    EXPECT_EQ(sorted_pairs(*bp), reference_pairs(boxes)) << GetParam();
    bp->set_groups(std::vector<std::uint32_t>(boxes.size() - 1, 0));
    EXPECT_THROW(sorted_pairs(*bp), Error) << GetParam() << ": group count differs from the box count";
  }
}

// A lone rigid body or obstacle has no candidate pair at all (today's main: one per pair of
// overlapping triangle boxes, dropped later by the narrow phase); next to a cloth, the candidates
// are exactly the cloth's pairs and the cloth-body pairs.
TEST_P(EveryBroadPhase, DetectorNeverPairsOneRigidBodyOrObstacleWithItself) {
  for (ObjectKind kind : {ObjectKind::rigid, ObjectKind::obstacle}) {
    gen::TriMesh ball = gen::sphere(0.1, 3);
    const test::TestScene lone =
        test::SceneBuilder().mesh("ball", kind, ball, kind == ObjectKind::rigid ? 1.0 : 0.0).finish();
    CollisionDetector det(lone.topo, lone.x, {0.005, 0.01, 0.0}, make_broad_phase(GetParam()));
    RegionSet regions;
    std::vector<ContactPair> contacts;
    DetectionStats stats;
    det.detect(lone.x, lone.inv_mass, regions, contacts, stats);
    EXPECT_EQ(stats.candidates, 0) << GetParam() << ", " << to_string(kind);
    EXPECT_TRUE(contacts.empty());

    gen::TriMesh cloth = gen::grid(0.3, 0.3, 12, 12);
    for (auto& p : cloth.v) p += Vec3(-0.15, 0.112, -0.15);  // 12 mm above: boxes overlap, no pair below ξ
    gen::TriMesh ball2 = ball;
    for (auto& p : ball2.v) p += Vec3(0.215, 0, 0);  // 15 mm from the first ball: pairs across bodies
    const test::TestScene s = test::SceneBuilder()
                                  .mesh("ball", kind, ball, kind == ObjectKind::rigid ? 1.0 : 0.0)
                                  .mesh("ball2", kind, ball2, kind == ObjectKind::rigid ? 1.0 : 0.0)
                                  .mesh("cloth", ObjectKind::cloth, cloth)
                                  .finish();
    CollisionDetector mixed(s.topo, s.x, {0.005, 0.01, 0.0}, make_broad_phase(GetParam()));
    mixed.detect(s.x, s.inv_mass, regions, contacts, stats);
    const CollisionPrimitives prims = build_collision_primitives(s.topo);
    std::vector<AABB> boxes;
    compute_primitive_boxes(prims, s.topo, s.x, box_inflation(0.005, 0.01, 0.0), boxes);
    Index expected = 0;
    for (const auto& [i, j] : reference_pairs(boxes)) {
      const Index oi = s.topo.face_object[i], oj = s.topo.face_object[j];
      const bool body_i = s.topo.objects[oi].kind == kind, body_j = s.topo.objects[oj].kind == kind;
      if (body_i && body_j && (oi == oj || kind == ObjectKind::obstacle)) continue;  // one body, or two obstacles
      ++expected;
    }
    EXPECT_GT(expected, 0);
    EXPECT_EQ(stats.candidates, expected) << GetParam() << ", " << to_string(kind);
  }
}

TEST_P(EveryBroadPhase, RejectsNonFiniteBoxes) {
  std::vector<AABB> boxes = random_soup(7, 100, 0.1);
  auto bp = make_broad_phase(GetParam());
  bp->build(boxes);
  boxes[17].hi.y() = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(bp->update(boxes), Error);
  auto fresh = make_broad_phase(GetParam());
  EXPECT_THROW(fresh->build(boxes), Error);
  boxes[17] = AABB{};  // an empty box: infinite bounds
  EXPECT_THROW(fresh->build(boxes), Error);
}

TEST_P(EveryBroadPhase, RejectsUpdateWithOtherCount) {
  auto bp = make_broad_phase(GetParam());
  bp->build(random_soup(8, 40, 0.1));
  EXPECT_THROW(bp->update(random_soup(8, 41, 0.1)), Error);
}

TEST_P(EveryBroadPhase, HandlesTinyInputs) {
  for (Index n : {0, 1, 2}) {
    auto bp = make_broad_phase(GetParam());
    std::vector<AABB> boxes(static_cast<size_t>(n), AABB::of(Vec3::Zero(), Vec3::Ones()));
    bp->build(boxes);
    std::vector<IndexPair> out{{5, 6}};
    bp->query_pairs(out);
    EXPECT_EQ(out.size(), n == 2 ? 1u : 0u) << GetParam() << " with " << n << " boxes";
  }
}

INSTANTIATE_TEST_SUITE_P(Collision, EveryBroadPhase, ::testing::ValuesIn(broad_phase_names()),
                         [](const auto& info) { return info.param; });

TEST(BroadPhaseFactory, ListsNamesAndRejectsUnknown) {
  const auto names = broad_phase_names();
  EXPECT_NE(std::find(names.begin(), names.end(), "fcl"), names.end());
  EXPECT_NE(std::find(names.begin(), names.end(), "bvh"), names.end());
  EXPECT_NE(std::find(names.begin(), names.end(), "brute_force"), names.end());
  EXPECT_NE(std::find(names.begin(), names.end(), std::string(default_broad_phase_name())), names.end());
  for (const auto& n : names) EXPECT_EQ(make_broad_phase(n)->name(), n);
  try {
    make_broad_phase("octree");
    FAIL() << "no exception";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("fcl"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("octree"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace ccfr
