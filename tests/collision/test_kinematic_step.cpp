// The separating-plane guarantee when one side is scripted (kinematic) and moves by a known step
// in the coming iteration: rotations included, where a closest-point bound is not enough.
#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include "ccfr/collision/collision_detector.hpp"
#include "ccfr/geometry/distance.hpp"
#include "scenes.hpp"
#include "test_support.hpp"

using namespace ccfr;

namespace {
constexpr double kXi = 0.01, kR = 0.005;

/// Random rigid step of the triangle: rotation about a random axis through a random point near it,
/// plus a translation, scaled so that no vertex moves more than `max_step`.
std::vector<Vec3> rigid_step(std::mt19937_64& g, const std::vector<Vec3>& tri, double max_step) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const Vec3 axis = Vec3(u(g), u(g), u(g)).normalized();
  const Vec3 centre = tri[0] + Vec3(u(g), u(g), u(g)) * 0.05;
  const Eigen::AngleAxisd rot(0.2 * u(g), axis);
  const Vec3 shift = Vec3(u(g), u(g), u(g)) * 0.002;
  std::vector<Vec3> step;
  double largest = 0.0;
  for (const auto& p : tri) {
    step.push_back(centre + rot * (p - centre) + shift - p);
    largest = std::max(largest, step.back().norm());
  }
  if (largest > max_step)
    for (auto& s : step) s *= max_step / largest;
  return step;
}

/// A random move within the ball of radius r that satisfies every half-space of `planes`.
bool admissible_move(std::mt19937_64& g, std::span<const HalfSpace> planes, Vec3& move) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int attempt = 0; attempt < 200; ++attempt) {
    const Vec3 m = Vec3(u(g), u(g), u(g)) * kR;
    if (m.norm() > kR) continue;
    bool ok = true;
    for (const auto& h : planes) ok = ok && h.n.dot(m) + h.d >= 0.0;
    if (ok) {
      move = m;
      return true;
    }
  }
  return false;
}
}  // namespace

TEST(KinematicStep, RotatingTriangleKeepsParticlesAndSegmentsBeyondXi) {
  auto g = ccfr::test::rng(404);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  int checked = 0;
  for (int trial = 0; trial < 3000; ++trial) {
    const std::vector<Vec3> tri{{0, 0, 0}, {0.08, 0, 0}, {0, 0, 0.08}};
    TopologyBuilder tb;
    tb.add_object("plate", ObjectKind::obstacle, 3, {{0, 2, 1}});
    const bool segment = trial % 2 == 1;
    if (segment)
      tb.add_object("wire", ObjectKind::strand, 2, {}, {}, {{0, 1}});
    else
      tb.add_object("grain", ObjectKind::particles, 1);
    const Topology topo = tb.finish();
    Positions x(tri.begin(), tri.end());
    const Vec3 above(0.06 * u(g), kXi + 2 * kR * u(g), 0.06 * u(g));
    x.push_back(above);
    if (segment) x.push_back(above + Vec3(0.03 * (u(g) - 0.5), 0.01 * u(g), 0.03 * (u(g) - 0.5)));
    std::vector<double> w(x.size(), 1.0);
    w[0] = w[1] = w[2] = 0.0;
    Positions step(x.size(), Vec3::Zero());
    const auto s = rigid_step(g, tri, kR);
    for (int k = 0; k < 3; ++k) step[k] = s[k];

    CollisionDetector det(topo, x, {kR, kXi, 0.0}, make_broad_phase("brute_force"));
    RegionSet regions;
    std::vector<ContactPair> contacts;
    DetectionStats stats;
    det.detect(x, w, regions, contacts, stats, step);
    bool feasible_anchor = true;
    for (Index v = 3; v < static_cast<Index>(x.size()); ++v)
      for (const auto& h : regions.of(v)) feasible_anchor = feasible_anchor && h.d >= 0.0;
    if (!feasible_anchor) continue;  // the obstacle closes in faster than the gap: d < 0 (clarification 7)

    Positions y = x;
    bool moved = true;
    for (int k = 0; k < 3; ++k) y[k] += step[k];
    for (Index v = 3; v < static_cast<Index>(x.size()); ++v) {
      Vec3 m;
      moved = moved && admissible_move(g, regions.of(v), m);
      y[v] += m;
    }
    if (!moved) continue;
    const double d =
        segment
            ? std::sqrt(std::min(
                  {edge_edge(y[3], y[4], y[0], y[1]).distance_sq, edge_edge(y[3], y[4], y[1], y[2]).distance_sq,
                   edge_edge(y[3], y[4], y[2], y[0]).distance_sq, point_triangle(y[3], y[0], y[1], y[2]).distance_sq,
                   point_triangle(y[4], y[0], y[1], y[2]).distance_sq}))
            : std::sqrt(point_triangle(y[3], y[0], y[1], y[2]).distance_sq);
    EXPECT_GE(d, kXi - 1e-9) << "trial " << trial << (segment ? " (segment)" : " (particle)");
    ++checked;
  }
  EXPECT_GT(checked, 1500);
}

namespace {
/// A pair at the edge of a scripted handle (OGC's twisted square): P and Q are handle vertices 5 mm
/// apart, a and c free. vf: P against the face (a, c, Q); ee: the handle edge (P', P) against the
/// edge (a, Q). The pair starts within [0.1, 1.5] ξ; the handle takes a rigid step or none.
struct HandlePair {
  ContactPair c;
  Positions x, step;
  std::vector<double> w;
};

HandlePair handle_pair(std::mt19937_64& g, bool edge_edge_pair, bool moving) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  constexpr double h = 0.005;
  HandlePair p;
  // 0 P, 1 Q, 2 a, 3 c (vf) or 3 P' (ee), all handle vertices on the z axis.
  p.x = {Vec3(0, 0, 0), Vec3(0, 0, h), Vec3(-h + 0.001 * u(g), 0.001 * u(g), 0.002 * u(g)), Vec3::Zero()};
  if (edge_edge_pair) {
    p.x[3] = Vec3(0, 0, -h);
    // a close to the handle's line near P: the edge (a, Q) passes P within about |a - P|.
    p.x[2] = Vec3(0.0015 * u(g), 0.0015 * u(g), 0.0005 * u(g));
  } else {
    // c near P: the face (a, c, Q) folded over P.
    p.x[3] = Vec3(0.0015 * u(g), 0.0015 * u(g), 0.0015 * u(g));
  }
  p.w = {0.0, 0.0, 1.0, edge_edge_pair ? 0.0 : 1.0};
  p.step.assign(4, Vec3::Zero());
  if (moving) {
    const Eigen::AngleAxisd rot(0.01 * u(g), Vec3(u(g), u(g), u(g)).normalized());
    const Vec3 centre(0.01 * u(g), 0.01 * u(g), 0.01 * u(g)), shift = Vec3(u(g), u(g), u(g)) * 0.0005;
    for (int k = 0; k < 4; ++k)
      if (p.w[k] == 0.0) p.step[k] = centre + rot * (p.x[k] - centre) + shift - p.x[k];
  }
  ContactPair& c = p.c;
  c.offset = kXi / 10.0;  // 1 mm against 5 mm edges, as in the scene
  if (edge_edge_pair) {
    c.kind = ContactKind::ee;
    c.v = {3, 0, 2, 1};
    const EdgeEdgeResult r = edge_edge(p.x[3], p.x[0], p.x[2], p.x[1]);
    c.distance = std::sqrt(r.distance_sq);
    c.n = (r.pa - r.pb).normalized();
    c.w = {1.0 - r.s, r.s, -(1.0 - r.t), -r.t};
  } else {
    c.kind = ContactKind::vf;
    c.v = {0, 2, 3, 1};
    const PointTriangleResult r = point_triangle(p.x[0], p.x[2], p.x[3], p.x[1]);
    c.distance = std::sqrt(r.distance_sq);
    const Vec3 closest = r.bary[0] * p.x[2] + r.bary[1] * p.x[3] + r.bary[2] * p.x[1];
    c.n = (p.x[0] - closest).normalized();
    c.w = {1.0, -r.bary[0], -r.bary[1], -r.bary[2]};
  }
  return p;
}

double handle_pair_distance(const HandlePair& p, const Positions& y) {
  return p.c.kind == ContactKind::ee ? std::sqrt(edge_edge(y[3], y[0], y[2], y[1]).distance_sq)
                                     : std::sqrt(point_triangle(y[0], y[2], y[3], y[1]).distance_sq);
}

/// Moves every free vertex of the pair within r inside its half-space of `rec` (side 0: n, d_A;
/// side 1: -n, d_B); false if a vertex found no such move.
bool move_within(std::mt19937_64& g, const HandlePair& p, const RegionRecord& rec, Positions& y) {
  for (int k = 0; k < p.c.size(); ++k) {
    const Index v = p.c.v[k];
    if (p.w[v] == 0.0) continue;
    const int side = k < p.c.side_a() ? 0 : 1;
    const HalfSpace h{side ? Vec3(-rec.n) : rec.n, rec.d[side]};
    Vec3 m;
    if (!admissible_move(g, std::span<const HalfSpace>(&h, 1), m)) return false;
    y[v] += m;
  }
  return true;
}

/// The least move of every free vertex onto its half-space of `rec` (what a projection of a
/// vertex that wants to stay does): onto the plane if it must move, nowhere otherwise.
Positions least_move(const HandlePair& p, const RegionRecord& rec, Positions y) {
  for (int k = 0; k < p.c.size(); ++k) {
    const Index v = p.c.v[k];
    if (p.w[v] == 0.0) continue;
    const int side = k < p.c.side_a() ? 0 : 1;
    const Vec3 n = side ? Vec3(-rec.n) : rec.n;
    y[v] += std::max(0.0, -rec.d[side]) * n;
  }
  return y;
}
}  // namespace

// A side holding a scripted vertex and a free one, inside the offset (or brought inside it by the
// handle's step): moving the free vertices along n by their share leaves the scripted ones where
// they are, so the usual split admits positions inside the offset; mixed_pair_record's plane does
// not. Every admissible move of the free vertices ends the pair at least its offset apart.
TEST(KinematicStep, MixedSidesKeepTheOffsetWhereTheShareSplitCannot) {
  auto g = ccfr::test::rng(2027);
  int checked = 0, split_failed = 0, tilted = 0;
  for (int trial = 0; trial < 4000; ++trial) {
    const HandlePair p = handle_pair(g, trial % 2 == 1, trial % 4 >= 2);
    const ContactPair& c = p.c;
    if (!(c.distance > 0.1 * c.offset && c.distance < 1.5 * c.offset)) continue;
    double k_a = 0.0, k_b = 0.0;
    for (int k = 0; k < c.size(); ++k) {
      const double along = c.n.dot(p.step[c.v[k]]);
      (k < c.side_a() ? k_a : k_b) = std::max(k < c.side_a() ? k_a : k_b, k < c.side_a() ? -along : along);
    }
    const double gap = c.distance - c.offset - k_a - k_b;
    if (!(gap < 0.0)) continue;  // the usual split is sound there
    const auto rec = mixed_pair_record(c, p.x, p.w, p.step, 0.0);
    ASSERT_TRUE(rec.has_value()) << "trial " << trial << ": the handle's vertices stay 5 mm apart";
    tilted += rec->n.dot(c.n) < 1.0 - 1e-12;
    Positions end = p.x;
    for (size_t k = 0; k < end.size(); ++k) end[k] += p.step[k];
    EXPECT_GE(handle_pair_distance(p, least_move(p, *rec, end)), c.offset * (1.0 - 1e-9)) << "trial " << trial;
    Positions y = end;
    if (!move_within(g, p, *rec, y)) continue;
    EXPECT_GE(handle_pair_distance(p, y), c.offset * (1.0 - 1e-9)) << "trial " << trial;
    ++checked;
    // The usual split on the same pair: the free vertices' share of the gap alone.
    const RegionRecord split{c.n, {0.0, gap}};
    split_failed += handle_pair_distance(p, least_move(p, split, end)) < c.offset * (1.0 - 1e-9);
  }
  EXPECT_GT(checked, 1500);
  EXPECT_GT(tilted, 500);        // half need the plane turned toward the handle
  EXPECT_GT(split_failed, 300);  // and the split it replaces lets them through
}

// The fixed vertices themselves inside the offset: no plane can separate them, and the record
// says so instead of inventing one.
TEST(KinematicStep, MixedPairWhoseFixedVerticesTouchHasNoPlane) {
  HandlePair p;
  p.x = {Vec3(0, 0, 0), Vec3(0, 0, 0.0005), Vec3(-0.005, 0, 0), Vec3(-0.005, 0, 0.005)};
  p.w = {0.0, 0.0, 1.0, 1.0};
  p.step.assign(4, Vec3::Zero());
  ContactPair& c = p.c;
  c.kind = ContactKind::vf;
  c.v = {0, 2, 3, 1};
  c.offset = 0.001;
  c.distance = 0.0004;
  c.n = Vec3(1, 0, 0);
  EXPECT_FALSE(mixed_pair_record(c, p.x, p.w, p.step, 0.0).has_value());
}

// A side whose closest point sits on a fixed vertex but which holds a free one (a cloth vertex
// beside a handle vertex): the free vertex can still turn its primitive about the fixed point,
// and it gets a share of the gap for it. With the paper's β-weighted share alone its room was 0
// in every such pair, and OGC's twisted square held a vertex beside the handle at its anchor for
// good. Every admissible move of the free vertices keeps the pair at least ξ apart.
TEST(KinematicStep, AFreeVertexBesideAFixedClosestPointGetsRoomAndStaysSound) {
  auto g = ccfr::test::rng(3034);
  std::uniform_real_distribution<double> u(0.0, 1.0), s(-1.0, 1.0);
  int checked = 0, with_room = 0;
  for (int trial = 0; trial < 2000; ++trial) {
    const bool face = trial % 2 == 1;
    TopologyBuilder tb;
    // Vertices 0 P (fixed), 1 f (free), 2 Q (fixed, face only); the other side: a free edge
    // (3, 4) over P, or a free particle (3).
    if (face)
      tb.add_object("handle", ObjectKind::cloth, 3, {{0, 1, 2}});
    else
      tb.add_object("handle", ObjectKind::strand, 2, {}, {}, {{0, 1}});
    if (face)
      tb.add_object("grain", ObjectKind::particles, 1);
    else
      tb.add_object("wire", ObjectKind::strand, 2, {}, {}, {{0, 1}});
    const Topology topo = tb.finish();
    // f (and Q) below P's level: the closest point of the handle's primitive is at P (or on PQ).
    const Vec3 p(0, 0, 0);
    const Vec3 f = p + 0.005 * Vec3(s(g), -0.2 - u(g), s(g)).normalized();
    Positions x{p, f};
    if (face) x.push_back(p + 0.005 * Vec3(s(g), -u(g) * 0.2, s(g)).normalized());
    const Vec3 above(0.002 * s(g), kXi / 10.0 * (1.05 + 2.0 * u(g)), 0.002 * s(g));
    x.push_back(above);
    if (!face) x.push_back(above + Vec3(0.006 * s(g), 0.001 * u(g), 0.006 * s(g)));
    std::vector<double> w(x.size(), 1.0);
    w[0] = 0.0;
    if (face) w[2] = 0.0;

    CollisionDetector det(topo, x, {kR, kXi / 10.0, 0.0}, make_broad_phase("brute_force"));
    RegionSet regions;
    std::vector<ContactPair> contacts;
    DetectionStats stats;
    det.detect(x, w, regions, contacts, stats, {});
    bool fixed_closest = false;
    for (const ContactPair& c : contacts)
      for (int k = 0; k < c.size(); ++k) fixed_closest = fixed_closest || (c.v[k] == 0 && std::abs(c.w[k]) > 0.5);
    if (!fixed_closest) continue;
    double room = std::numeric_limits<double>::infinity();
    for (const auto& h : regions.of(1)) room = std::min(room, h.d);
    with_room += room > 0.0;

    Positions y = x;
    bool moved = true;
    for (Index v = 0; v < static_cast<Index>(x.size()); ++v) {
      if (w[v] == 0.0) continue;
      Vec3 m;
      moved = moved && admissible_move(g, regions.of(v), m);
      y[v] += m;
    }
    if (!moved) continue;
    const double d = face ? std::sqrt(point_triangle(y[3], y[0], y[1], y[2]).distance_sq)
                          : std::sqrt(edge_edge(y[0], y[1], y[2], y[3]).distance_sq);
    EXPECT_GE(d, kXi / 10.0 * (1.0 - 1e-9)) << "trial " << trial << (face ? " (face)" : " (edge)");
    ++checked;
  }
  EXPECT_GT(checked, 1000);
  EXPECT_GT(with_room, 9 * checked / 10);
}
