// The compact region (issue 38 item 1): one record per contact and, per vertex, references into
// the records. Its planes must equal, bit for bit, the per-vertex copies built directly from the
// contacts (Alg. NarrowPhase lines 10/26/41), including degenerate input.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <random>
#include <vector>

#include "ccfr/collision/collision_detector.hpp"
#include "ccfr/feasibility/projector.hpp"
#include "scenes.hpp"
#include "test_support.hpp"

namespace ccfr {
namespace {

const ContactModel kParams{0.005, 0.01, 0.0005};

bool same_bits(const HalfSpace& a, const HalfSpace& b) {
  return std::memcmp(a.n.data(), b.n.data(), 3 * sizeof(double)) == 0 && std::memcmp(&a.d, &b.d, sizeof(double)) == 0;
}

/// The per-vertex rows as the narrow phase wrote them before the compact region: for every
/// contact in order, each movable vertex of side A gets (n, s_A φ), of side B (-n, s_B φ), with
/// s_A = W_A / (W_A + W_B), W a side's barycentric-weighted inverse masses, the weight its
/// immovable vertices hold counted at the mean inverse mass of its movable ones (0 if none moves).
std::vector<std::vector<HalfSpace>> brute_rows(const std::vector<ContactPair>& contacts,
                                               const std::vector<double>& inv_mass, Index nv) {
  std::vector<std::vector<HalfSpace>> rows(static_cast<size_t>(nv));
  for (const ContactPair& c : contacts) {
    const int na = c.side_a();
    double weight[2] = {0.0, 0.0}, fixed[2] = {0.0, 0.0}, sum[2] = {0.0, 0.0};
    int movable[2] = {0, 0};
    for (int k = 0; k < c.size(); ++k) {
      const double w = inv_mass[static_cast<size_t>(c.v[k])];
      const int side = k < na ? 0 : 1;
      if (w > 0.0) {
        weight[side] += std::abs(c.w[k]) * w;
        sum[side] += w;
        ++movable[side];
      } else {
        fixed[side] += std::abs(c.w[k]);
      }
    }
    for (int side = 0; side < 2; ++side)
      weight[side] = movable[side] > 0 ? weight[side] + fixed[side] * (sum[side] / movable[side]) : 0.0;
    const double sa = weight[0] + weight[1] > 0.0 ? weight[0] / (weight[0] + weight[1]) : 0.0;
    const double phi = c.distance - c.offset;
    for (int k = 0; k < c.size(); ++k) {
      if (!(inv_mass[static_cast<size_t>(c.v[k])] > 0.0)) continue;
      rows[static_cast<size_t>(c.v[k])].push_back(HalfSpace{k < na ? c.n : Vec3(-c.n), (k < na ? sa : 1.0 - sa) * phi});
    }
  }
  return rows;
}

/// Detects at x and checks the records and references against brute_rows: the counts, every
/// gathered row bit for bit, the by-value range, and the screen without gather against the free
/// falls_below over the brute-force row at random candidates.
void check_scene(const test::TestScene& s, const Positions& x, std::uint64_t seed) {
  CollisionDetector det(s.topo, s.x, kParams, make_broad_phase("bvh"));
  RegionSet regions;
  std::vector<ContactPair> contacts;
  DetectionStats stats;
  det.detect(x, s.inv_mass, regions, contacts, stats);
  ASSERT_GT(contacts.size(), 0u);
  const Index nv = s.topo.num_vertices();
  const auto rows = brute_rows(contacts, s.inv_mass, nv);
  // One record per contact; one 4-byte reference per (contact, movable vertex).
  EXPECT_EQ(regions.records.size(), contacts.size());
  size_t slots = 0;
  for (const auto& r : rows) slots += r.size();
  EXPECT_EQ(regions.total(), slots);
  EXPECT_EQ(regions.refs.size(), slots);
  ASSERT_EQ(regions.num_vertices(), nv);
  auto g = test::rng(seed);
  std::uniform_real_distribution<double> u(-0.01, 0.01);
  std::vector<HalfSpace> buf;
  for (Index v = 0; v < nv; ++v) {
    const auto& row = rows[static_cast<size_t>(v)];
    ASSERT_EQ(static_cast<size_t>(regions.count(v)), row.size()) << "vertex " << v;
    const auto span = regions.of(v, buf);
    ASSERT_EQ(span.size(), row.size());
    size_t k = 0;
    for (const HalfSpace& h : regions.planes_of(v)) {
      EXPECT_TRUE(same_bits(span[k], row[k])) << "vertex " << v << ", plane " << k;
      EXPECT_TRUE(same_bits(h, row[k])) << "vertex " << v << ", plane " << k;
      EXPECT_TRUE(same_bits(regions.plane(regions.row_start[v] + static_cast<Index>(k)), row[k]));
      ++k;
    }
    EXPECT_EQ(k, row.size());
    for (int trial = 0; trial < 8; ++trial) {
      const Vec3 cand = x[v] + Vec3(u(g), u(g), u(g));
      for (double level : {0.0, -1e-3})
        EXPECT_EQ(regions.falls_below(v, x[v], cand, level), falls_below(x[v], cand, row, level)) << "vertex " << v;
    }
  }
}

TEST(CompactRegion, RecordsAndReferencesGiveTheBruteForceRowsOnAFoldedCloth) {
  test::ExpectWarnings expect_warnings;  // edges finer than 2ξ: neighbours start closer than ξ
  const gen::TriMesh cloth = test::accordion_cloth(0.2, 16, 3, 0.008, 0.002);
  gen::TriMesh floor;
  floor.v = {Vec3(-1, -0.02, -1), Vec3(1, -0.02, -1), Vec3(-1, -0.02, 1), Vec3(1, -0.02, 1)};
  floor.f = {Vec3i(0, 2, 1), Vec3i(1, 2, 3)};
  test::TestScene s = test::SceneBuilder()
                          .mesh("cloth", ObjectKind::cloth, cloth)
                          .mesh("floor", ObjectKind::obstacle, floor, 0.0)
                          .finish();
  // Uneven masses, so the shares differ from 1/2, and a few pinned vertices (no planes).
  for (size_t i = 0; i < cloth.v.size(); ++i) s.inv_mass[i] = i % 17 == 0 ? 0.0 : 1.0 + static_cast<double>(i % 5);
  check_scene(s, s.x, 1);
}

// Degenerate input: a zero-area triangle (collinear corners), parallel strand segments,
// coincident particles (no normal: no contact, no record) and an obstacle at rest under them.
TEST(CompactRegion, RecordsAndReferencesGiveTheBruteForceRowsOnDegenerateInput) {
  test::ExpectWarnings expect_warnings;  // coincident particles and close segments at rest
  const test::TestScene s = test::degenerate_mixed_scene();
  check_scene(s, s.x, 2);
  // The coincident grains came within range with no normal: counted degenerate, no record.
  CollisionDetector det(s.topo, s.x, kParams, make_broad_phase("bvh"));
  RegionSet regions;
  std::vector<ContactPair> contacts;
  DetectionStats stats;
  det.detect(s.x, s.inv_mass, regions, contacts, stats);
  EXPECT_GT(stats.degenerate, 0);
  EXPECT_EQ(regions.records.size(), contacts.size());
}

// Rows given per vertex (build_region_set) get one record each and read back unchanged; an empty
// region set has no planes and no records.
TEST(CompactRegion, BuildRegionSetKeepsEveryPlane) {
  std::vector<std::vector<TaggedHalfSpace>> buf(2);
  buf[0] = {{2, 5, {Vec3(0, 1, 0), 0.25}}, {0, 1, {Vec3(1, 0, 0), -0.0}}};
  buf[1] = {{2, 3, {Vec3(0, 0, -1), 1e-300}}};
  RegionSet r;
  build_region_set(3, buf, r);
  ASSERT_EQ(r.total(), 3u);
  EXPECT_EQ(r.records.size(), 3u);
  EXPECT_EQ(r.count(1), 0);
  EXPECT_TRUE(same_bits(r.of(0)[0], {Vec3(1, 0, 0), -0.0}));
  EXPECT_TRUE(same_bits(r.of(2)[0], {Vec3(0, 0, -1), 1e-300}));  // key 3 before key 5
  EXPECT_TRUE(same_bits(r.of(2)[1], {Vec3(0, 1, 0), 0.25}));
  // An empty row: never outside at a finite level (min_value's +infinity), as the free function.
  EXPECT_EQ(r.falls_below(1, Vec3::Zero(), Vec3::Ones(), 0.0), falls_below(Vec3::Zero(), Vec3::Ones(), {}, 0.0));
  r.clear(4);
  EXPECT_EQ(r.num_vertices(), 4);
  EXPECT_EQ(r.total(), 0u);
  EXPECT_TRUE(r.records.empty());
}

}  // namespace
}  // namespace ccfr
