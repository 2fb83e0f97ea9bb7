// push_through (docs/feasibility.md, "Passing a push on through a resting pile") on a column of
// vertices resting at the offset from each other (every gap 0): a fixed vertex below (or two, one
// at each end) pushes the first one up by K. Independent answers: the sum of each pair's offsets
// (its gap), the chain's least motions worked out by hand, and the distances the pairs keep when
// a pushed-on side stays at its anchor.
#include <gtest/gtest.h>

#include <vector>

#include "ccfr/solvers/motion_planes.hpp"

using namespace ccfr;

namespace {

constexpr double kXi = 0.004;

/// Vertices 0..n-1 at y = k ξ; vertex-vertex contacts (k, k+1), A the lower id, normal from B to A
/// (down), records {d_A, d_B} = {0, 0} (gap 0) except those a fixed vertex makes: its movable
/// neighbour gets -K (the fixed vertex approaches by K). `fixed` lists the fixed vertices.
struct Column {
  std::vector<ContactPair> contacts;
  RegionSet regions;
  std::vector<double> inv_mass;
};

Column column(int n, const std::vector<int>& fixed, double k_push) {
  Column c;
  c.inv_mass.assign(static_cast<size_t>(n), 1.0);
  for (int f : fixed) c.inv_mass[static_cast<size_t>(f)] = 0.0;
  auto movable = [&](int v) { return c.inv_mass[static_cast<size_t>(v)] > 0.0; };
  c.regions.clear(n);
  std::vector<std::vector<std::uint32_t>> refs(static_cast<size_t>(n));
  for (int k = 0; k + 1 < n; ++k) {
    ContactPair p;
    p.kind = ContactKind::vv;
    p.v = {k, k + 1, -1, -1};
    p.w = {1.0, -1.0, 0.0, 0.0};
    p.n = Vec3(0, -1, 0);
    p.distance = p.offset = kXi;
    RegionRecord rec;
    rec.n = p.n;
    if (!movable(k)) rec.d[1] = -k_push;      // the fixed vertex below rises by K
    if (!movable(k + 1)) rec.d[0] = -k_push;  // the fixed vertex above comes down by K
    const auto r = static_cast<std::uint32_t>(c.contacts.size());
    if (movable(k)) refs[static_cast<size_t>(k)].push_back(2 * r);
    if (movable(k + 1)) refs[static_cast<size_t>(k + 1)].push_back(2 * r + 1);
    c.contacts.push_back(p);
    c.regions.records.push_back(rec);
  }
  for (int v = 0; v < n; ++v) {
    c.regions.row_start[static_cast<size_t>(v) + 1] =
        c.regions.row_start[static_cast<size_t>(v)] + static_cast<Index>(refs[static_cast<size_t>(v)].size());
    for (auto r : refs[static_cast<size_t>(v)]) c.regions.refs.push_back(r);
  }
  return c;
}

}  // namespace

TEST(PushThrough, APushFromAFixedVertexIsPassedUpAColumnAtRestWithEveryGapKept) {
  const double k_push = 0.2e-3;
  Column c = column(6, {0}, k_push);
  const std::vector<RegionRecord> before = c.regions.records;
  const Index moved = push_through(c.regions, c.contacts, c.inv_mass, {}, 64);
  EXPECT_EQ(moved, 4);  // the four free pairs above the fixed one
  // The fixed vertex's own contact is not rewritten.
  EXPECT_EQ(c.regions.records[0].d[0], before[0].d[0]);
  EXPECT_EQ(c.regions.records[0].d[1], before[0].d[1]);
  // Each free pair: d_A + d_B = its gap (0); the lower side may rise by its push and 10 % halved
  // each round, the upper must rise by as much: K 1.1, K 1.1 1.05, K 1.1 1.05 1.025, ...
  double need = k_push, margin = 0.1;
  for (size_t p = 1; p < c.contacts.size(); ++p) {
    const RegionRecord& r = c.regions.records[p];
    EXPECT_NEAR(r.d[0] + r.d[1], 0.0, 1e-18) << p;
    need *= 1.0 + margin;
    margin *= 0.5;
    EXPECT_NEAR(r.d[0], need, 1e-15) << p;
    // The least motions the planes ask (vertex p+1 up by -d_B) keep the pair exactly at ξ, and a
    // pushed-on vertex left at its anchor still keeps it ξ - d_A >= ξ/2 away.
    EXPECT_GE(kXi - r.d[0], 0.5 * kXi) << p;
  }
  EXPECT_LT(need, k_push * 1.23);  // the margins compound to at most e^0.2
}

TEST(PushThrough, APushLargerThanHalfTheOffsetIsCappedSoThatAHaltedSideIsNotCrossed) {
  Column c = column(4, {0}, 0.8 * kXi);
  push_through(c.regions, c.contacts, c.inv_mass, {}, 64);
  for (size_t p = 1; p < c.contacts.size(); ++p) {
    EXPECT_DOUBLE_EQ(c.regions.records[p].d[0], 0.5 * kXi) << p;
    EXPECT_DOUBLE_EQ(c.regions.records[p].d[1], -0.5 * kXi) << p;
  }
}

TEST(PushThrough, PushesFromBothEndsAlikeAreLeftAsASqueezeAndNoPushLeavesTheGapUnchanged) {
  // Fixed vertices at both ends push the two free ones toward each other by the same amount.
  Column c = column(4, {0, 3}, 0.2e-3);
  push_through(c.regions, c.contacts, c.inv_mass, {}, 64);
  EXPECT_EQ(c.regions.records[1].d[0], 0.0);
  EXPECT_EQ(c.regions.records[1].d[1], 0.0);
  // Nothing pushed (K = 0): nothing moves.
  Column still = column(5, {0}, 0.0);
  EXPECT_EQ(push_through(still.regions, still.contacts, still.inv_mass, {}, 64), 0);
  // A contact list that does not match the records (one record per plane) is left alone.
  Column odd = column(5, {0}, 0.2e-3);
  odd.regions.records.push_back(RegionRecord{});
  EXPECT_EQ(push_through(odd.regions, odd.contacts, odd.inv_mass, {}, 64), 0);
}
