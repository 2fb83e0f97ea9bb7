// The planes of a contact between a movable side and an unpinned rigid body (docs/feasibility.md,
// "A vertex carried by a body"): split_by_motion takes the body's generalized inverse mass where
// the response gave it one, and mark_carried names the movable vertices a body both comes onto and
// leaves. Independent answers: the split's closed form worked by hand from the shares, and the
// vertices' contacts read off the set-up.
#include <gtest/gtest.h>

#include <vector>

#include "ccfr/solvers/motion_planes.hpp"

using namespace ccfr;

namespace {

constexpr double kXi = 0.005, kGap = 0.001;

/// Vertex-vertex contacts with records {d_A, d_B} = {G/2, G/2}; `pairs` lists (A, B, n).
struct Pairs {
  std::vector<ContactPair> contacts;
  RegionSet regions;
};

Pairs pairs(int vertices, const std::vector<std::tuple<Index, Index, Vec3>>& list) {
  Pairs p;
  p.regions.clear(vertices);
  for (const auto& [a, b, n] : list) {
    ContactPair c;
    c.kind = ContactKind::vv;
    c.v = {a, b, -1, -1};
    c.w = {1.0, -1.0, 0.0, 0.0};
    c.n = n;
    c.distance = kXi + kGap;
    c.offset = kXi;
    RegionRecord rec;
    rec.n = n;
    rec.d[0] = rec.d[1] = 0.5 * kGap;
    p.contacts.push_back(c);
    p.regions.records.push_back(rec);
  }
  return p;
}

}  // namespace

TEST(SplitByMotion, ARigidSideSharesTheOverlapByItsGeneralizedInverseMass) {
  // A cloth vertex (0: 10 g) below a body's vertex (1: 0.1 g of the body's mass, the body's
  // generalized inverse mass at the contact 2 /kg), normal from the body down to the cloth. The
  // cloth rises 0.6 G, the body comes down 0.8 G: they overlap by 0.4 G, which the split cuts by
  // the shares s_A = w_A / (w_A + w_B): d_A = a_A + s_A (G - a_A - a_B).
  const Vec3 down(0, -1, 0);
  Pairs p = pairs(2, {{0, 1, down}});
  const Positions anchor = {Vec3(0, 0, 0), Vec3(0, kXi + kGap, 0)};
  const Positions x = {Vec3(0, 0.6 * kGap, 0), Vec3(0, kXi + kGap - 0.8 * kGap, 0)};
  const std::vector<double> inv_mass = {100.0, 1e4}, responds = {100.0, 0.0}, other = {2.0};
  std::vector<HeldSplit> held;
  split_by_motion(p.regions, p.contacts, anchor, x, inv_mass, responds, held, other);
  const double s_a = 100.0 / (100.0 + 2.0);
  EXPECT_NEAR(p.regions.records[0].d[0], 0.6 * kGap + s_a * (kGap - 0.6 * kGap - 0.8 * kGap), 1e-15);
  EXPECT_NEAR(p.regions.records[0].d[0] + p.regions.records[0].d[1], kGap, 1e-18);
  // By the body's vertex mass instead, the light vertex would take nearly all of the overlap and
  // leave the cloth the room it asked for.
  Pairs q = pairs(2, {{0, 1, down}});
  split_by_motion(q.regions, q.contacts, anchor, x, inv_mass, responds, held);
  const double s_vertex = 100.0 / (100.0 + 1e4);
  EXPECT_NEAR(q.regions.records[0].d[0], 0.6 * kGap + s_vertex * (kGap - 0.6 * kGap - 0.8 * kGap), 1e-15);
  EXPECT_GT(q.regions.records[0].d[0], 2.5 * p.regions.records[0].d[0]);
}

TEST(MarkCarried, AVertexABodyComesOntoAndLeavesIsCarriedByIt) {
  // Body 0: vertices 1 (above the cloth) and 2 (below); body 1: vertex 3 (below). Every body
  // vertex moves down by 2 G. Cloth vertices: 0 between 1 and 2 (1 comes on past the gap, 2
  // leaves): carried by body 0. 4 under 1 alone: only come onto. 5 under 1 and above 3 (another
  // body leaves it): not carried. 6 above 2 (leaves) and under 1 with the room of its gap. 7 as
  // 0, with the body on side A of both its contacts (the normal then points to the body).
  const Vec3 up(0, 1, 0), down(0, -1, 0);
  Pairs p = pairs(8, {{0, 1, down},
                      {0, 2, up},
                      {4, 1, down},
                      {5, 1, down},
                      {5, 3, up},
                      {6, 2, up},
                      {6, 1, down},
                      {1, 7, up},
                      {2, 7, down}});
  Positions anchor(8, Vec3::Zero()), x(8, Vec3::Zero());
  for (Index v : {1, 2, 3}) x[v] = anchor[v] + Vec3(0, -2.0 * kGap, 0);
  // Vertex 6's contact with 1: the body comes on by 2 G along a normal tilted by 70 degrees,
  // 0.68 G along it, within the gap.
  p.contacts[6].n = p.regions.records[6].n = Vec3(std::sin(1.2217), -std::cos(1.2217), 0);
  const std::vector<Index> body = {-1, 0, 0, 1, -1, -1, -1, -1};
  const std::vector<double> movable = {1, 0, 0, 0, 1, 1, 1, 1};
  std::vector<Index> carrier;
  EXPECT_EQ(mark_carried(p.contacts, p.regions, anchor, x, body, movable, carrier), 2);
  EXPECT_EQ(carrier, (std::vector<Index>{0, -1, -1, -1, -1, -1, -1, 0}));
  EXPECT_TRUE(moves_with_one_body(p.contacts[7], body, carrier));
  // One motion moves a pair whole only where every vertex is on, or carried by, one body.
  EXPECT_TRUE(moves_with_one_body(p.contacts[0], body, carrier));
  EXPECT_TRUE(moves_with_one_body(p.contacts[1], body, carrier));
  EXPECT_FALSE(moves_with_one_body(p.contacts[2], body, carrier));
  EXPECT_FALSE(moves_with_one_body(p.contacts[4], body, carrier));
  // A pair between a carried vertex and a body that does not carry it is not moved whole.
  carrier[5] = 0;
  EXPECT_FALSE(moves_with_one_body(p.contacts[4], body, carrier));
  EXPECT_TRUE(moves_with_one_body(p.contacts[3], body, carrier));
}

TEST(MarkCarried, NothingIsCarriedWhereTheRecordsAreNotOnePerContact) {
  Pairs p = pairs(3, {{0, 1, Vec3(0, -1, 0)}, {0, 2, Vec3(0, 1, 0)}});
  p.regions.records.pop_back();
  const Positions anchor(3, Vec3::Zero());
  Positions x = anchor;
  x[1] = x[2] = Vec3(0, -2.0 * kGap, 0);
  std::vector<Index> carrier = {5, 5, 5};
  EXPECT_EQ(mark_carried(p.contacts, p.regions, anchor, x, std::vector<Index>{-1, 0, 0}, std::vector<double>{1, 0, 0},
                         carrier),
            0);
  EXPECT_EQ(carrier, (std::vector<Index>{-1, -1, -1}));
}
