// The method's guarantee (design clarification 4): for any displacements of the vertices of a
// pair that stay inside their half-spaces, the pair stays at least ξ apart. Checked for every
// pair kind, with dynamic, weighted, pinned and kinematic sides, on random configurations and
// on degenerate ones (parallel edges, zero-area triangles, zero-length edges, coincident points).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>

#include "ccfr/collision/collision_detector.hpp"
#include "ccfr/geometry/distance.hpp"
#include "scenes.hpp"
#include "test_support.hpp"

namespace ccfr {
namespace {

constexpr double kR = 0.005, kXi = 0.01;
const ContactModel kParams{kR, kXi, 0.0005};

/// Smallest distance between the collision primitives of objects 0 and 1 of `s` at `x`,
/// through the kernels: vertex-face both ways, edge-edge, vertex-edge and vertex-vertex as the
/// objects' kinds call for.
double object_distance(const Topology& t, const Positions& x) {
  const ObjectInfo &o0 = t.objects[0], &o1 = t.objects[1];
  double best = std::numeric_limits<double>::infinity();
  auto vertices = [&](const ObjectInfo& o) {
    std::vector<Index> v;
    for (Index i = o.vertex_begin; i < o.vertex_end; ++i) v.push_back(i);
    return v;
  };
  auto edges = [&](const ObjectInfo& o) {
    std::vector<Vec2i> e;
    for (Index i = 0; i < t.num_edges(); ++i)
      if (t.edge_object[i] == static_cast<Index>(&o - t.objects.data())) e.push_back(t.edges[i]);
    return e;
  };
  auto faces = [&](const ObjectInfo& o) {
    return std::vector<Vec3i>(t.faces.begin() + o.face_begin, t.faces.begin() + o.face_end);
  };
  for (int side = 0; side < 2; ++side) {
    const ObjectInfo &a = side ? o1 : o0, &b = side ? o0 : o1;
    for (Index v : vertices(a)) {
      for (const Vec3i& f : faces(b))
        best = std::min(best, std::sqrt(point_triangle(x[v], x[f[0]], x[f[1]], x[f[2]]).distance_sq));
      for (const Vec2i& e : edges(b)) best = std::min(best, std::sqrt(point_edge(x[v], x[e[0]], x[e[1]]).distance_sq));
      if (side == 0)
        for (Index u : vertices(b)) best = std::min(best, (x[v] - x[u]).norm());
    }
  }
  for (const Vec2i& e : edges(o0))
    for (const Vec2i& f : edges(o1))
      best = std::min(best, std::sqrt(edge_edge(x[e[0]], x[e[1]], x[f[0]], x[f[1]]).distance_sq));
  return best;
}

/// A displacement of vertex v inside the ball of radius r that satisfies all its half-spaces:
/// uniform samples, half of them pushed onto the boundary of one of the planes (the worst case
/// along its normal). Returns false when none was found.
bool sample_admissible(std::mt19937_64& g, const RegionSet& regions, Index v, const Vec3& x, Vec3& out) {
  const auto planes = regions.of(v);
  std::uniform_int_distribution<size_t> pick(0, planes.empty() ? 0 : planes.size() - 1);
  for (int attempt = 0; attempt < 20000; ++attempt) {
    Vec3 dx = test::random_in_ball(g, kR);
    if (!planes.empty() && attempt % 2 == 0) {
      const HalfSpace& h = planes[pick(g)];
      dx -= (dx.dot(h.n) + h.d) * h.n;
      if (dx.norm() > kR) continue;
    }
    const Vec3 y = x + dx;
    if (std::all_of(planes.begin(), planes.end(), [&](const HalfSpace& h) { return h.value(x, y) >= -1e-15; })) {
      out = y;
      return true;
    }
  }
  return false;
}

struct PairCase {
  test::TestScene scene;  ///< objects 0 and 1 form the pair
};

/// Detects at s.x (exclusions computed from a configuration where the objects are 1 m apart, so
/// nothing is excluded), then samples admissible displacements and checks the distance.
/// Returns the number of half-spaces, or -1 when the pair was out of range.
Index check_separation(const test::TestScene& s, std::mt19937_64& g, int samples, double& min_seen) {
  Positions far = s.x;
  for (Index v = s.topo.objects[1].vertex_begin; v < s.topo.objects[1].vertex_end; ++v) far[v] += Vec3(1, 1, 1);
  CollisionDetector det(s.topo, far, kParams, make_broad_phase("bvh"));
  RegionSet regions;
  std::vector<ContactPair> contacts;
  DetectionStats stats;
  det.detect(s.x, s.inv_mass, regions, contacts, stats);
  const double before = object_distance(s.topo, s.x);
  if (before - kXi >= 2 * kR) {
    EXPECT_TRUE(contacts.empty());
    return -1;
  }
  EXPECT_FALSE(contacts.empty()) << "pair at distance " << before << " not detected";
  for (const HalfSpace& h : regions.rows()) EXPECT_TRUE(h.n.allFinite() && std::isfinite(h.d));
  for (int k = 0; k < samples; ++k) {
    Positions y = s.x;
    bool ok = true;
    for (Index v = 0; v < s.topo.num_vertices() && ok; ++v)
      if (s.inv_mass[v] > 0) ok = sample_admissible(g, regions, v, s.x[v], y[v]);
    if (!ok) continue;  // an empty region inside the ball (pair deep inside ξ): nothing to check
    const double after = object_distance(s.topo, y);
    min_seen = std::min(min_seen, after);
    EXPECT_GE(after, kXi - 1e-9) << "separation lost: " << before << " -> " << after;
    if (after < kXi - 1e-9) return static_cast<Index>(regions.total());
  }
  return static_cast<Index>(regions.total());
}

using Maker = std::function<test::TestScene(std::mt19937_64&, double w0, double w1)>;

Vec3 random_point(std::mt19937_64& g, double scale) {
  std::uniform_real_distribution<double> u(-scale, scale);
  return Vec3(u(g), u(g), u(g));
}

/// Moves object 1 rigidly so that its distance to object 0 is a random value in
/// [min_distance, ξ + 2r + r/2]: in range, out of range and possibly inside the offset.
void place(test::TestScene& s, std::mt19937_64& g, double min_distance) {
  std::uniform_real_distribution<double> target(min_distance, kXi + 2.5 * kR);
  const Index b = s.topo.objects[1].vertex_begin, e = s.topo.objects[1].vertex_end;
  const double want = target(g);
  // Pull object 1 toward object 0 along the line between their centroids by bisection.
  Vec3 c0 = Vec3::Zero(), c1 = Vec3::Zero();
  for (Index v = s.topo.objects[0].vertex_begin; v < s.topo.objects[0].vertex_end; ++v)
    c0 += s.x[v] / s.topo.objects[0].num_vertices();
  for (Index v = b; v < e; ++v) c1 += s.x[v] / (e - b);
  Vec3 dir = c1 - c0;
  if (dir.norm() < 1e-9) dir = Vec3::UnitY();
  dir.normalize();
  const Positions base = s.x;
  auto at = [&](double t) {
    for (Index v = b; v < e; ++v) s.x[v] = base[v] + t * dir;
    return object_distance(s.topo, s.x);
  };
  double hi = 0.05;
  while (at(hi) < want) hi *= 2;
  // The distance is 1-Lipschitz in t: walk toward object 0 in steps of r/10 until the first
  // configuration closer than wanted, then bisect the last step.
  const double step = 0.1 * kR;
  double lo = hi;
  while (lo > -0.2 && at(lo) >= want) {
    hi = lo;
    lo -= step;
  }
  for (int it = 0; it < 50; ++it) {
    const double mid = 0.5 * (lo + hi);
    (at(mid) < want ? lo : hi) = mid;
  }
  at(hi);
}

void run_kind(const char* what, const Maker& make, int configs, double min_distance = kXi - 0.5 * kR) {
  auto g = test::rng(0xC0FFEE);
  std::uniform_real_distribution<double> mass(0.2, 3.0);
  double min_seen = std::numeric_limits<double>::infinity();
  int checked = 0;
  for (int c = 0; c < configs; ++c) {
    // Mass cases: both dynamic with random weights, one side kinematic, the other side kinematic.
    const int mode = c % 3;
    const double w0 = mode == 1 ? 0.0 : mass(g), w1 = mode == 2 ? 0.0 : mass(g);
    test::TestScene s = make(g, w0, w1);
    place(s, g, min_distance);
    if (check_separation(s, g, 40, min_seen) >= 0) ++checked;
    if (::testing::Test::HasFailure()) {
      ADD_FAILURE() << what << ": config " << c << " (mode " << mode << ")";
      return;
    }
  }
  EXPECT_GT(checked, configs / 2) << what;
  // The bound is tight: boundary samples bring the pair close to ξ.
  EXPECT_LT(min_seen, kXi + 0.5 * kR) << what;
}

test::TestScene triangle_and(std::mt19937_64& g, double w0, double w1, ObjectKind other, int other_vertices) {
  gen::TriMesh tri{{random_point(g, 0.02), random_point(g, 0.02), random_point(g, 0.02)}, {Vec3i(0, 1, 2)}};
  test::SceneBuilder b;
  b.mesh("tri", w0 == 0 ? ObjectKind::obstacle : ObjectKind::cloth, tri, w0);
  if (other == ObjectKind::particles) {
    b.particles("p", {Vec3(0, 0.05, 0) + random_point(g, 0.01)}, w1);
  } else if (other == ObjectKind::strand) {
    gen::PolylineSet s;
    for (int i = 0; i < other_vertices; ++i) s.v.push_back(Vec3(0, 0.05, 0) + random_point(g, 0.02));
    s.lines = {{0, 1}};
    b.strands("s", s, w1);
  } else {
    gen::TriMesh t2{{Vec3(0, 0.05, 0) + random_point(g, 0.02), Vec3(0, 0.05, 0) + random_point(g, 0.02),
                     Vec3(0, 0.05, 0) + random_point(g, 0.02)},
                    {Vec3i(0, 1, 2)}};
    b.mesh("tri2", ObjectKind::cloth, t2, w1);
  }
  return b.finish();
}

TEST(SeparatingPlane, VertexFace) {
  run_kind(
      "vertex-face", [](auto& g, double w0, double w1) { return triangle_and(g, w0, w1, ObjectKind::particles, 1); },
      150);
}

TEST(SeparatingPlane, TriangleTriangle) {
  // Vertex-face both ways and edge-edge: the whole triangle pair stays ξ apart.
  run_kind(
      "triangle-triangle", [](auto& g, double w0, double w1) { return triangle_and(g, w0, w1, ObjectKind::cloth, 3); },
      150);
}

TEST(SeparatingPlane, TriangleSegment) {
  run_kind(
      "triangle-segment", [](auto& g, double w0, double w1) { return triangle_and(g, w0, w1, ObjectKind::strand, 2); },
      150);
}

test::TestScene segment_and(std::mt19937_64& g, double w0, double w1, bool other_is_segment) {
  gen::PolylineSet s;
  s.v = {random_point(g, 0.02), random_point(g, 0.02)};
  s.lines = {{0, 1}};
  test::SceneBuilder b;
  b.strands("s", s, w0);
  if (other_is_segment) {
    gen::PolylineSet t;
    t.v = {Vec3(0, 0.05, 0) + random_point(g, 0.02), Vec3(0, 0.05, 0) + random_point(g, 0.02)};
    t.lines = {{0, 1}};
    b.strands("t", t, w1);
  } else {
    b.particles("p", {Vec3(0, 0.05, 0) + random_point(g, 0.01)}, w1);
  }
  return b.finish();
}

TEST(SeparatingPlane, EdgeEdge) {
  run_kind(
      "edge-edge", [](auto& g, double w0, double w1) { return segment_and(g, w0, w1, true); }, 150);
}

TEST(SeparatingPlane, VertexEdge) {
  run_kind(
      "vertex-edge", [](auto& g, double w0, double w1) { return segment_and(g, w0, w1, false); }, 150);
}

TEST(SeparatingPlane, VertexVertex) {
  run_kind(
      "vertex-vertex",
      [](auto& g, double w0, double w1) {
        return test::SceneBuilder()
            .particles("a", {random_point(g, 0.01)}, w0)
            .particles("b", {Vec3(0, 0.03, 0)}, w1)
            .finish();
      },
      150);
}

TEST(SeparatingPlane, PinnedVertexInsideDynamicTriangle) {
  // Only from outside the offset: a pinned vertex cannot take its share of a negative gap (a
  // pair already closer than ξ whose closest point is partly carried by a pinned vertex); see
  // docs/collision.md, "Limits".
  run_kind(
      "pinned corner",
      [](auto& g, double w0, double w1) {
        test::TestScene s = triangle_and(g, w0 == 0 ? 1.0 : w0, w1 == 0 ? 1.0 : w1, ObjectKind::cloth, 3);
        s.inv_mass[0] = 0.0;  // one pinned corner in each triangle
        s.inv_mass[4] = 0.0;
        return s;
      },
      90, kXi);
}

TEST(SeparatingPlaneDegenerate, ParallelEdges) {
  auto g = test::rng(5);
  double min_seen = std::numeric_limits<double>::infinity();
  for (double gap : {0.0105, 0.013, 0.019}) {
    for (double shift : {0.0, 0.01, 0.03}) {
      gen::PolylineSet a, b;
      a.v = {Vec3(0, 0, 0), Vec3(0.04, 0, 0)};
      b.v = {Vec3(shift, gap, 0), Vec3(shift + 0.04, gap, 0)};
      a.lines = b.lines = {{0, 1}};
      const test::TestScene s = test::SceneBuilder().strands("a", a).strands("b", b).finish();
      EXPECT_GE(check_separation(s, g, 200, min_seen), 4) << "gap " << gap << " shift " << shift;
    }
  }
  EXPECT_LT(min_seen, kXi + 0.002);
}

TEST(SeparatingPlaneDegenerate, ZeroAreaTriangleAndZeroLengthEdge) {
  auto g = test::rng(6);
  double min_seen = std::numeric_limits<double>::infinity();
  // Collinear triangle vs particle.
  gen::TriMesh sliver{{Vec3(0, 0, 0), Vec3(0.02, 0, 0), Vec3(0.04, 0, 0)}, {Vec3i(0, 1, 2)}};
  test::TestScene s = test::SceneBuilder()
                          .mesh("sliver", ObjectKind::cloth, sliver)
                          .particles("p", {Vec3(0.03, 0.012, 0.001)})
                          .finish();
  EXPECT_GE(check_separation(s, g, 300, min_seen), 4);
  // Triangle with two coincident corners vs a segment.
  gen::TriMesh needle{{Vec3(0, 0, 0), Vec3(0.03, 0, 0), Vec3(0.03, 0, 0)}, {Vec3i(0, 1, 2)}};
  gen::PolylineSet seg;
  seg.v = {Vec3(0.01, 0.013, -0.02), Vec3(0.01, 0.013, 0.02)};
  seg.lines = {{0, 1}};
  s = test::SceneBuilder().mesh("needle", ObjectKind::cloth, needle).strands("s", seg).finish();
  EXPECT_GE(check_separation(s, g, 300, min_seen), 4);
  // Zero-length strand segment vs particle.
  gen::PolylineSet dot;
  dot.v = {Vec3(0, 0, 0), Vec3(0, 0, 0)};
  dot.lines = {{0, 1}};
  s = test::SceneBuilder().strands("dot", dot).particles("p", {Vec3(0.0, 0.015, 0.0)}).finish();
  EXPECT_GE(check_separation(s, g, 300, min_seen), 3);
}

TEST(SeparatingPlaneDegenerate, CoincidentPoints) {
  // Coincident at detection time (apart initially): no normal exists; the pair is reported as
  // degenerate and produces neither a half-space nor a NaN.
  const test::TestScene s =
      test::SceneBuilder().particles("a", {Vec3(0, 0, 0)}).particles("b", {Vec3(0.5, 0, 0)}).finish();
  CollisionDetector det(s.topo, s.x, kParams, make_broad_phase("bvh"));
  Positions x = s.x;
  x[1] = x[0];
  RegionSet regions;
  std::vector<ContactPair> contacts;
  DetectionStats stats;
  det.detect(x, s.inv_mass, regions, contacts, stats);
  EXPECT_EQ(stats.degenerate, 1);
  EXPECT_TRUE(contacts.empty());
  EXPECT_EQ(regions.total(), 0u);
  // Coincident in the initial configuration, and not neighbours on any mesh: kept with the
  // reduced offset 0 (initial proximity), so still degenerate and without a half-space; once
  // apart, the offset rises with the distance.
  test::ExpectWarnings expect;
  CollisionDetector det0(s.topo, x, kParams, make_broad_phase("fcl"));
  EXPECT_FALSE(det0.is_excluded(ContactKind::vv, 0, 1));
  EXPECT_EQ(det0.initial_proximity().reduced_offset, 1);
  EXPECT_EQ(det0.pair_offset(ContactKind::vv, 0, 1), 0.0);
  det0.detect(x, s.inv_mass, regions, contacts, stats);
  EXPECT_EQ(stats.excluded_initial, 0);
  EXPECT_EQ(stats.degenerate, 1);
  EXPECT_TRUE(contacts.empty());
  x[1] = x[0] + Vec3(0.004, 0, 0);
  det0.detect(x, s.inv_mass, regions, contacts, stats);
  ASSERT_EQ(contacts.size(), 1u);
  EXPECT_DOUBLE_EQ(contacts[0].offset, 0.9 * 0.004);
  EXPECT_DOUBLE_EQ(det0.pair_offset(ContactKind::vv, 0, 1), 0.9 * 0.004);
}

TEST(SeparatingPlane, SharesFollowInverseMasses) {
  // Particle above the interior of a triangle: the particle takes w_p / (w_p + w_f) of φ, each
  // triangle vertex w_f / (w_p + w_f); a kinematic triangle leaves the whole gap to the particle.
  gen::TriMesh tri{{Vec3(-0.1, 0, -0.1), Vec3(0.1, 0, -0.1), Vec3(0, 0, 0.1)}, {Vec3i(0, 1, 2)}};
  for (double wf : {0.0, 1.0, 3.0}) {
    const test::TestScene s = test::SceneBuilder()
                                  .mesh("tri", wf == 0 ? ObjectKind::obstacle : ObjectKind::cloth, tri, wf)
                                  .particles("p", {Vec3(0, 0.016, 0)}, 1.0)
                                  .finish();
    Positions far = s.x;
    far[3].y() = 1.0;
    CollisionDetector det(s.topo, far, kParams, make_broad_phase("brute_force"));
    RegionSet regions;
    std::vector<ContactPair> contacts;
    DetectionStats stats;
    det.detect(s.x, s.inv_mass, regions, contacts, stats);
    ASSERT_EQ(contacts.size(), 1u);
    const double phi = 0.016 - kXi;
    ASSERT_EQ(regions.count(3), 1);
    EXPECT_NEAR(regions.of(3)[0].d, phi * 1.0 / (1.0 + wf), 1e-15);
    EXPECT_NEAR((regions.of(3)[0].n - Vec3::UnitY()).norm(), 0.0, 1e-15);
    for (Index v = 0; v < 3; ++v) {
      ASSERT_EQ(regions.count(v), wf == 0 ? 0 : 1);
      if (wf == 0) continue;
      EXPECT_NEAR(regions.of(v)[0].d, phi * wf / (1.0 + wf), 1e-15);
      EXPECT_NEAR((regions.of(v)[0].n + Vec3::UnitY()).norm(), 0.0, 1e-15);
    }
    EXPECT_EQ(stats.constraints, wf == 0 ? 1 : 4);
  }
}

}  // namespace
}  // namespace ccfr
