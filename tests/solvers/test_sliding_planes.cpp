// The sliding planes keep the guarantee (docs/feasibility.md, "Sliding planes"): a plane turned by
// turn_by_motion still separates its pair by the offset for every displacement its half-spaces
// admit, and still holds the anchors. Independent answer: the exact distance kernels on random
// pairs moved to random points of their turned half-spaces.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "ccfr/geometry/distance.hpp"
#include "ccfr/solvers/motion_planes.hpp"

using namespace ccfr;

namespace {

/// One vertex-face or edge-edge pair at positions `x` (vertices 0-3), found as the detector finds
/// it: closest points, normal from B to A, distance and offset.
ContactPair make_pair(ContactKind kind, const Positions& x, double offset) {
  ContactPair c;
  c.kind = kind;
  c.v = {0, 1, 2, 3};
  c.offset = offset;
  Vec3 pa, pb;
  if (kind == ContactKind::vf) {
    const PointTriangleResult r = point_triangle(x[0], x[1], x[2], x[3]);
    c.w = {1.0, -r.bary[0], -r.bary[1], -r.bary[2]};
    pa = x[0];
    pb = r.closest;
  } else {
    const EdgeEdgeResult r = edge_edge(x[0], x[1], x[2], x[3]);
    c.w = {1.0 - r.s, r.s, -(1.0 - r.t), -r.t};
    pa = r.pa;
    pb = r.pb;
  }
  c.distance = (pa - pb).norm();
  c.n = (pa - pb) / c.distance;
  return c;
}

double pair_distance(ContactKind kind, const Positions& x) {
  return std::sqrt(kind == ContactKind::vf ? point_triangle(x[0], x[1], x[2], x[3]).distance_sq
                                           : edge_edge(x[0], x[1], x[2], x[3]).distance_sq);
}

TEST(SlidingPlanes, ATurnedPlaneKeepsItsPairTheOffsetApartAndItsAnchorsInside) {
  std::mt19937 rng(54);
  std::uniform_real_distribution<double> u(-1.0, 1.0), unit(0.0, 1.0);
  const double offset = 0.01, r = 0.01;
  int turned = 0, checked = 0;
  for (int trial = 0; trial < 4000; ++trial) {
    const ContactKind kind = trial % 2 == 0 ? ContactKind::vf : ContactKind::ee;
    // Side B near the origin in the plane y = 0 (a floor triangle or edge), side A above it by
    // the offset plus up to 2r, shifted sideways so that its closest point is often on B's boundary.
    Positions anchor(4);
    anchor[1] = Vec3(u(rng), 0.0, u(rng)) * 0.05;
    anchor[2] = Vec3(u(rng), 0.0, u(rng)) * 0.05;
    anchor[3] = Vec3(u(rng), 0.0, u(rng)) * 0.05;
    if (kind == ContactKind::ee) std::swap(anchor[0], anchor[2]);  // edges (0, 1) and (2, 3)
    const Vec3 lift(0.05 * u(rng), offset + 2.0 * r * unit(rng), 0.05 * u(rng));
    if (kind == ContactKind::vf) {
      anchor[0] = lift;
    } else {
      anchor[0] = lift;
      anchor[1] = lift + Vec3(u(rng), 0.2 * u(rng), u(rng)) * 0.03;
      anchor[2] = Vec3(u(rng), 0.0, u(rng)) * 0.05;
      anchor[3] = Vec3(u(rng), 0.0, u(rng)) * 0.05;
    }
    const ContactPair found = make_pair(kind, anchor, offset);
    if (!(found.distance > offset)) continue;
    // Candidates: side A slid sideways and pushed down by up to 2r, side B fixed or moving.
    const bool b_moves = trial % 3 == 0;
    Positions x = anchor;
    const Vec3 slide(2.0 * r * u(rng), -2.0 * r * unit(rng), 2.0 * r * u(rng));
    for (int k = 0; k < found.side_a(); ++k) x[k] += slide;
    std::vector<double> inv_mass(4, 0.0);
    for (int k = 0; k < 4; ++k) inv_mass[k] = k < found.side_a() || b_moves ? 1.0 : 0.0;
    if (b_moves)
      for (int k = found.side_a(); k < 4; ++k) x[k] += Vec3(u(rng), u(rng), u(rng)) * r;
    const double gap = found.distance - offset;
    const double s_a = b_moves ? 0.5 : 1.0;
    std::vector<ContactPair> contacts{found};
    RegionSet regions;
    regions.records = {RegionRecord{found.n, {s_a * gap, (1.0 - s_a) * gap}}};
    if (turn_by_motion(contacts, regions, anchor, x, inv_mass, {}, 0.0005) == 0) continue;
    ++turned;
    const RegionRecord& rec = regions.records[0];
    const ContactPair& c = contacts[0];
    ASSERT_EQ(rec.n, c.n);
    EXPECT_NEAR(rec.n.norm(), 1.0, 1e-12);
    EXPECT_GE(rec.d[0], 0.0);  // each anchor inside its own half-space
    EXPECT_GE(rec.d[1], 0.0);
    EXPECT_NEAR(rec.d[0] + rec.d[1], c.distance - c.offset, 1e-15);
    EXPECT_LE(c.distance, found.distance * (1.0 + 1e-12));  // the closest-point normal maximises the gap
    // Random points of the turned half-spaces: each vertex at its candidate, moved along ±m to a
    // random depth inside its plane (side A: m·(p − a) >= −d_A; side B: m·(p − a) <= d_B).
    for (int sample = 0; sample < 8; ++sample) {
      Positions p = x;
      for (int k = 0; k < 4; ++k) {
        if (!(inv_mass[k] > 0.0)) continue;
        const bool a_side = k < c.side_a();
        const double along = rec.n.dot(p[k] - anchor[k]), bound = a_side ? -rec.d[0] : rec.d[1];
        const double depth = unit(rng) * r;  // how far inside the plane it ends
        const double target =
            a_side ? std::max(along, bound + depth * unit(rng)) : std::min(along, bound - depth * unit(rng));
        p[k] += (target - along) * rec.n;
      }
      ++checked;
      EXPECT_GE(pair_distance(kind, p), offset * (1.0 - 1e-9)) << "trial " << trial;
    }
  }
  EXPECT_GT(turned, 200) << "too few turns to test";
  EXPECT_GT(checked, 1600);
}

TEST(SlidingPlanes, APairThatIsNotBlockedOrHasNoGapKeepsItsPlane) {
  // The candidates inside the plane and beyond the repulsion: nothing to turn. And a pair at
  // exactly its offset (G = 0) has no gap to turn with.
  Positions anchor{Vec3(0.3, 0.02, 0.0), Vec3(-1, 0, -1), Vec3(1, 0, -1), Vec3(0, 0, 1)};
  const ContactPair found = make_pair(ContactKind::vf, anchor, 0.01);
  std::vector<double> inv_mass{1.0, 0.0, 0.0, 0.0};
  for (const double offset : {0.01, 0.02}) {
    std::vector<ContactPair> contacts{found};
    contacts[0].offset = offset;
    const double gap = contacts[0].distance - offset;
    RegionSet regions;
    regions.records = {RegionRecord{found.n, {gap, 0.0}}};
    Positions x = anchor;
    x[0] += offset == 0.01 ? Vec3(0.01, 0.0, 0.0) : Vec3(0.01, -0.005, 0.0);
    EXPECT_EQ(turn_by_motion(contacts, regions, anchor, x, inv_mass, {}, 0.0), 0);
    EXPECT_EQ(regions.records[0].n, found.n);
  }
}

}  // namespace
