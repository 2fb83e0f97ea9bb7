// The narrow phase against an all-pairs loop over the same distance kernels, the half-space
// properties, exclusions, determinism, degenerate input and the separating-plane guarantee.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <map>
#include <random>
#include <set>
#include <string>

#include "ccfr/collision/collision_detector.hpp"
#include "ccfr/collision/primitives.hpp"
#include "ccfr/core/error.hpp"
#include "ccfr/core/parallel.hpp"
#include "ccfr/geometry/distance.hpp"
#include "scenes.hpp"
#include "test_support.hpp"

namespace ccfr {
namespace {

constexpr double kR = 0.005, kXi = 0.01, kDelta = 0.0005;
const ContactModel kParams{kR, kXi, kDelta};

/// A sub-pair named by its vertices: kind, side A (sorted, padded), side B (sorted, padded);
/// the two sides of the symmetric kinds (ee, vv) in lexicographic order.
using SubPairName = std::array<Index, 6>;

SubPairName name_of(ContactKind kind, std::vector<Index> a, std::vector<Index> b) {
  std::sort(a.begin(), a.end());
  std::sort(b.begin(), b.end());
  if ((kind == ContactKind::ee || kind == ContactKind::vv) && b < a) std::swap(a, b);
  a.resize(2, -1);
  b.resize(3, -1);
  return {static_cast<Index>(kind), a[0], a[1], b[0], b[1], b[2]};
}

SubPairName name_of(const ContactPair& c) {
  std::vector<Index> a(c.v.begin(), c.v.begin() + c.side_a()), b(c.v.begin() + c.side_a(), c.v.begin() + c.size());
  return name_of(c.kind, a, b);
}

bool no_self(const Topology& t, Index object) {
  const ObjectKind k = t.objects[object].kind;
  return k == ObjectKind::rigid || k == ObjectKind::obstacle;
}

/// Every sub-pair of the scene, tested directly: vertex-face for every collision vertex against
/// every face, edge-edge for every pair of edges, vertex-edge for points against strand segments,
/// vertex-vertex between points. Calls fn(kind, a, b, sideA, weightsA, sideB, weightsB, dist_sq)
/// for the sub-pairs that share no vertex and are not inside one rigid or obstacle object.
template <class Fn>
void for_each_sub_pair(const test::TestScene& s, const Positions& x, Fn fn) {
  const Topology& t = s.topo;
  std::vector<bool> is_point(static_cast<size_t>(t.num_vertices()), false), collides(is_point.size(), false);
  std::vector<bool> is_segment(static_cast<size_t>(t.num_edges()), false);
  for (Index e = 0; e < t.num_edges(); ++e) {
    is_segment[e] = t.objects[t.edge_object[e]].kind == ObjectKind::strand;
    if (is_segment[e]) collides[t.edges[e][0]] = collides[t.edges[e][1]] = true;
  }
  for (Index v = 0; v < t.num_vertices(); ++v) {
    const ObjectKind k = t.object_of_vertex(v).kind;
    if (t.vertex_faces.row(v).size() > 0) collides[v] = true;
    if (k == ObjectKind::particles || (k == ObjectKind::strand && t.vertex_edges.row(v).empty())) {
      is_point[v] = true;
      collides[v] = true;
    }
  }
  for (Index v = 0; v < t.num_vertices(); ++v) {
    if (!collides[v]) continue;
    for (Index f = 0; f < t.num_faces(); ++f) {
      const Vec3i& tri = t.faces[f];
      if (tri[0] == v || tri[1] == v || tri[2] == v) continue;
      if (t.vertex_object[v] == t.face_object[f] && no_self(t, t.face_object[f])) continue;
      const PointTriangleResult r = point_triangle(x[v], x[tri[0]], x[tri[1]], x[tri[2]]);
      fn(ContactKind::vf, v, f, std::vector<Index>{v}, std::vector<double>{1.0},
         std::vector<Index>{tri[0], tri[1], tri[2]}, std::vector<double>{r.bary[0], r.bary[1], r.bary[2]},
         r.distance_sq);
    }
  }
  for (Index e0 = 0; e0 < t.num_edges(); ++e0)
    for (Index e1 = e0 + 1; e1 < t.num_edges(); ++e1) {
      const Vec2i &a = t.edges[e0], &b = t.edges[e1];
      if (a[0] == b[0] || a[0] == b[1] || a[1] == b[0] || a[1] == b[1]) continue;
      if (t.edge_object[e0] == t.edge_object[e1] && no_self(t, t.edge_object[e0])) continue;
      const EdgeEdgeResult r = edge_edge(x[a[0]], x[a[1]], x[b[0]], x[b[1]]);
      fn(ContactKind::ee, e0, e1, std::vector<Index>{a[0], a[1]}, std::vector<double>{1 - r.s, r.s},
         std::vector<Index>{b[0], b[1]}, std::vector<double>{1 - r.t, r.t}, r.distance_sq);
    }
  for (Index v = 0; v < t.num_vertices(); ++v) {
    if (!is_point[v]) continue;
    for (Index e = 0; e < t.num_edges(); ++e) {
      if (!is_segment[e]) continue;
      const Vec2i& seg = t.edges[e];
      const PointEdgeResult r = point_edge(x[v], x[seg[0]], x[seg[1]]);
      fn(ContactKind::ve, v, e, std::vector<Index>{v}, std::vector<double>{1.0}, std::vector<Index>{seg[0], seg[1]},
         std::vector<double>{1 - r.t, r.t}, r.distance_sq);
    }
    for (Index u = v + 1; u < t.num_vertices(); ++u)
      if (is_point[u])
        fn(ContactKind::vv, v, u, std::vector<Index>{v}, std::vector<double>{1.0}, std::vector<Index>{u},
           std::vector<double>{1.0}, point_point_distance_sq(x[v], x[u]));
  }
}

/// The sub-pairs within range (φ < 2r; under a per-vertex reach ρ, closer than ρ_A + ρ_B + ξ with
/// ρ_A, ρ_B the sides' largest) that are not excluded and have a movable vertex.
std::multiset<SubPairName> brute_force_contacts(const test::TestScene& s, const Positions& x,
                                                const CollisionDetector& det,
                                                const std::vector<double>* vertex_reach = nullptr) {
  std::multiset<SubPairName> out;
  auto side_reach = [&](const std::vector<Index>& side) {
    double r = 0.0;
    for (Index v : side) r = std::max(r, (*vertex_reach)[static_cast<size_t>(v)]);
    return r;
  };
  for_each_sub_pair(s, x,
                    [&](ContactKind kind, Index a, Index b, const std::vector<Index>& va, const std::vector<double>& wa,
                        const std::vector<Index>& vb, const std::vector<double>& wb, double dist_sq) {
                      const double reach = vertex_reach ? side_reach(va) + side_reach(vb) + kXi : 2 * kR + kXi;
                      if (dist_sq >= reach * reach || det.is_excluded(kind, a, b)) return;
                      bool movable = false;
                      for (Index v : va) movable = movable || s.inv_mass[v] > 0;
                      for (Index v : vb) movable = movable || s.inv_mass[v] > 0;
                      if (movable && std::sqrt(dist_sq) >= 1e-12) out.insert(name_of(kind, va, vb));
                    });
  return out;
}

test::TestScene folded_cloth_scene() {
  return test::SceneBuilder()
      .mesh("cloth", ObjectKind::cloth, test::accordion_cloth(0.2, 18, 2, 0.011, 0.003))
      .finish();
}

test::TestScene strand_scene() {
  return test::SceneBuilder().strands("hair", gen::curly_strands(16, 16, 0.15, 0.03, 0.008, 2.0)).finish();
}

test::TestScene mixed_scene() {
  gen::TriMesh cloth = test::accordion_cloth(0.12, 10, 1, 0.011, 0.002);
  gen::TriMesh ball = gen::sphere(0.05, 1);
  for (auto& p : ball.v) p += Vec3(0, -0.062, 0);
  gen::PolylineSet hair = gen::curly_strands(6, 12, 0.08, 0.02, 0.006, 1.5);
  for (auto& p : hair.v) p += Vec3(0.02, 0.12, 0.0);
  Positions dust = gen::particle_block(4, 2, 4, 0.011);
  for (auto& p : dust) p += Vec3(0.0, 0.04, 0.0);
  gen::TetMesh jelly = gen::tet_box(Vec3(0.03, 0.03, 0.03), Vec3i(2, 2, 2));
  for (auto& p : jelly.v) p += Vec3(-0.03, 0.045, 0.03);
  gen::TriMesh crate = gen::box(Vec3(0.02, 0.02, 0.02));
  for (auto& p : crate.v) p += Vec3(0.04, 0.035, -0.03);
  gen::PolylineSet lone;
  lone.v = {Vec3(0.03, 0.03, 0.0)};
  lone.lines = {{0}};
  return test::SceneBuilder()
      .mesh("cloth", ObjectKind::cloth, cloth)
      .mesh("ball", ObjectKind::obstacle, ball, 0.0)
      .strands("hair", hair)
      .particles("dust", dust, 2.0)
      .tets("jelly", jelly, 0.5)
      .mesh("crate", ObjectKind::rigid, crate, 0.25)
      .strands("lone", lone)
      .finish();
}

void perturb(Positions& x, std::uint64_t seed, double r) {
  auto g = test::rng(seed);
  for (auto& p : x) p += test::random_in_ball(g, r);
}

struct Detection {
  RegionSet regions;
  std::vector<ContactPair> contacts;
  DetectionStats stats;
};

Detection run(CollisionDetector& det, const Positions& x, const std::vector<double>& w) {
  Detection d;
  det.detect(x, w, d.regions, d.contacts, d.stats);
  return d;
}

class NarrowPhaseScenes : public ::testing::TestWithParam<int> {
 protected:
  // The scenes start with neighbours closer than ξ (edges of 0.8 ξ, curls of close strands):
  // the detector warns about the exclusions and reduced offsets, as it should.
  test::ExpectWarnings expect_warnings_;
  test::TestScene scene() const {
    switch (GetParam()) {
      case 0:
        return folded_cloth_scene();
      case 1:
        return strand_scene();
      default:
        return mixed_scene();
    }
  }
};

TEST_P(NarrowPhaseScenes, MatchesAllPairsLoopEachSubPairOnce) {
  const test::TestScene s = scene();
  CollisionDetector det(s.topo, s.x, kParams, make_broad_phase(default_broad_phase_name()));
  Positions x = s.x;
  for (int pass = 0; pass < 3; ++pass) {
    if (pass > 0) perturb(x, 40 + pass, 0.004);
    const Detection d = run(det, x, s.inv_mass);
    std::multiset<SubPairName> found;
    for (const auto& c : d.contacts) found.insert(name_of(c));
    const std::multiset<SubPairName> expected = brute_force_contacts(s, x, det);
    EXPECT_GT(expected.size(), 0u);
    EXPECT_EQ(found, expected) << "pass " << pass << ": " << found.size() << " found, " << expected.size()
                               << " expected";
    EXPECT_EQ(std::set<SubPairName>(found.begin(), found.end()).size(), found.size()) << "a sub-pair came up twice";
    EXPECT_EQ(d.stats.pairs_within_range, static_cast<Index>(d.contacts.size()) + d.stats.degenerate);
  }
}

// contact.adaptive_reach: with a reach per vertex (random in [0, r], some exactly 0 or r, a
// vertex's own and one shared by all), every broad phase finds exactly the sub-pairs closer than
// the sides' largest reaches plus ξ, each once; with every reach r the uniform pass's contacts.
// Under a per-vertex reach the broad phase reports exactly the primitive pairs (with a movable
// primitive) whose boxes, grown by their vertices' largest reach and ξ/2, overlap: no δ/2, which
// only let through pairs the range ρ_A + ρ_B + ξ then rejects. Counted by an all-pairs loop over
// boxes computed here, for each broad phase, in the pass that builds the tree and one that refits it.
TEST_P(NarrowPhaseScenes, PerVertexReachBoxesLeaveOutTheRepulsionBand) {
  const test::TestScene s = scene();
  const size_t nv = static_cast<size_t>(s.topo.num_vertices());
  const CollisionPrimitives prims = build_collision_primitives(s.topo);
  auto vertices_of = [&](Index p) -> std::vector<Index> {
    const Index e = prims.element(p);
    switch (prims.kind(p)) {
      case PrimitiveKind::triangle:
        return {s.topo.faces[e][0], s.topo.faces[e][1], s.topo.faces[e][2]};
      case PrimitiveKind::edge:
        return {s.topo.edges[e][0], s.topo.edges[e][1]};
      case PrimitiveKind::point:
        return {e};
    }
    return {};
  };
  auto expected_pairs = [&](const Positions& x, const std::vector<double>& reach) {
    std::vector<AABB> box(static_cast<size_t>(prims.size()));
    std::vector<bool> movable(static_cast<size_t>(prims.size()), false);
    for (Index p = 0; p < prims.size(); ++p) {
      double grow = 0.0;
      for (Index v : vertices_of(p)) {
        box[p].expand(x[v]);
        grow = std::max(grow, reach[static_cast<size_t>(v)]);
        movable[p] = movable[p] || s.inv_mass[v] > 0.0;
      }
      box[p].inflate(0.5 * kXi + grow);
    }
    // Two triangles of one rigid body or obstacle never meet (face_no_self): not enumerated.
    auto one_body = [&](Index p, Index q) {
      return q < prims.num_triangles && prims.face_no_self[p] && s.topo.face_object[p] == s.topo.face_object[q];
    };
    Index count = 0;
    for (Index p = 0; p < prims.size(); ++p)
      for (Index q = p + 1; q < prims.size(); ++q)
        count += (movable[p] || movable[q]) && !one_body(p, q) && box[p].overlaps(box[q]);
    return count;
  };
  auto g = test::rng(5);
  std::uniform_real_distribution<double> u(0.0, kR);
  std::vector<double> reach(nv);
  for (double& r : reach) r = u(g);
  reach[0] = 0.0;
  for (const auto& name : broad_phase_names()) {
    CollisionDetector det(s.topo, s.x, kParams, make_broad_phase(name));
    Positions x = s.x;
    for (int pass = 0; pass < 2; ++pass) {
      perturb(x, 13 + pass, 0.002);
      Detection d;
      det.detect(x, s.inv_mass, d.regions, d.contacts, d.stats, {}, reach);
      const Index expected = expected_pairs(x, reach);
      EXPECT_GT(expected, 0) << name;
      EXPECT_EQ(d.stats.candidates, expected) << name << ", pass " << pass;
    }
  }
}

TEST_P(NarrowPhaseScenes, PerVertexReachMatchesAllPairsLoopWithinTheSumOfReaches) {
  const test::TestScene s = scene();
  const size_t nv = static_cast<size_t>(s.topo.num_vertices());
  Positions x = s.x;
  perturb(x, 7, 0.003);
  auto g = test::rng(11);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<std::vector<double>> reaches = {std::vector<double>(nv, 0.0), std::vector<double>(nv, kR),
                                              std::vector<double>(nv, 0.3 * kR)};
  std::vector<double> mixed(nv);
  for (double& r : mixed) {
    const double q = u(g);
    r = q < 0.2 ? 0.0 : (q > 0.8 ? kR : q * kR);
  }
  reaches.push_back(mixed);
  for (const auto& name : broad_phase_names()) {
    CollisionDetector det(s.topo, s.x, kParams, make_broad_phase(name));
    const Detection uniform = run(det, x, s.inv_mass);
    for (size_t k = 0; k < reaches.size(); ++k) {
      const std::string where = name + ", reach set " + std::to_string(k);
      Detection d;
      det.detect(x, s.inv_mass, d.regions, d.contacts, d.stats, {}, reaches[k]);
      std::multiset<SubPairName> found;
      for (const auto& c : d.contacts) found.insert(name_of(c));
      const std::multiset<SubPairName> expected = brute_force_contacts(s, x, det, &reaches[k]);
      EXPECT_EQ(found, expected) << where << ": " << found.size() << " found, " << expected.size() << " expected";
      EXPECT_EQ(std::set<SubPairName>(found.begin(), found.end()).size(), found.size()) << where;
      if (k == 1) {
        std::multiset<SubPairName> same;
        for (const auto& c : uniform.contacts) same.insert(name_of(c));
        EXPECT_EQ(found, same) << where;
      }
      if (k == 3) EXPECT_LT(found.size(), uniform.contacts.size()) << where;
    }
    Detection d;
    EXPECT_THROW(det.detect(x, s.inv_mass, d.regions, d.contacts, d.stats, {}, std::vector<double>(nv + 1, kR)), Error);
  }
}

TEST_P(NarrowPhaseScenes, HalfSpacesAreConsistentWithContacts) {
  const test::TestScene s = scene();
  CollisionDetector det(s.topo, s.x, kParams, make_broad_phase("bvh"));
  Positions x = s.x;
  perturb(x, 9, 0.003);
  const Detection d = run(det, x, s.inv_mass);
  ASSERT_EQ(d.regions.num_vertices(), s.topo.num_vertices());
  Index expected_planes = 0;
  for (const auto& c : d.contacts) {
    // Σ w_k x_k = x_A − x_B = distance · n, and side weights sum to ±1.
    Vec3 diff = Vec3::Zero();
    double sum_a = 0, sum_b = 0;
    for (int k = 0; k < c.size(); ++k) {
      diff += c.w[k] * x[c.v[k]];
      (k < c.side_a() ? sum_a : sum_b) += c.w[k];
      if (s.inv_mass[c.v[k]] > 0) ++expected_planes;
    }
    EXPECT_NEAR(sum_a, 1.0, 1e-12);
    EXPECT_NEAR(sum_b, -1.0, 1e-12);
    EXPECT_LT((diff - c.distance * c.n).norm(), 1e-12);
    EXPECT_NEAR(c.n.norm(), 1.0, 1e-12);
    EXPECT_LT(c.distance - kXi, 2 * kR);
  }
  EXPECT_EQ(d.stats.constraints, expected_planes);
  EXPECT_EQ(static_cast<Index>(d.regions.total()), expected_planes);
  for (Index v = 0; v < s.topo.num_vertices(); ++v)
    if (s.inv_mass[v] == 0) EXPECT_EQ(d.regions.count(v), 0) << "kinematic vertex " << v << " got half-spaces";
  // A vertex's planes appear in contact order: walk the contacts with a cursor per vertex and
  // check each plane against the contact it came from (Alg. NarrowPhase lines 10/26/41).
  std::vector<Index> cursor(d.regions.row_start.begin(), d.regions.row_start.end() - 1);
  for (const auto& c : d.contacts) {
    const double phi = c.distance - c.offset;
    EXPECT_LT(phi, 2 * kR);
    double share_sum = 0.0;
    int sides_movable = 0;
    for (int side = 0; side < 2; ++side) {
      double side_share = -1.0;
      for (int k = side == 0 ? 0 : c.side_a(); k < (side == 0 ? c.side_a() : c.size()); ++k) {
        const Index v = c.v[k];
        if (!(s.inv_mass[v] > 0)) continue;
        ASSERT_LT(cursor[v], d.regions.row_start[v + 1]) << "vertex " << v << " has fewer planes than contacts";
        const HalfSpace& h = d.regions.plane(static_cast<size_t>(cursor[v]++));
        // The normal points from the other primitive toward the vertex (clarification 3).
        EXPECT_EQ(h.n, side == 0 ? c.n : Vec3(-c.n));
        // d = s φ with a share s in [0, 1], the same for every vertex of a side.
        const double share = phi != 0.0 ? h.d / phi : 0.5;
        EXPECT_GE(share, -1e-12);
        EXPECT_LE(share, 1.0 + 1e-12);
        if (side_share < 0.0) side_share = share;
        EXPECT_NEAR(share, side_share, 1e-12);
        // The anchor itself is admissible whenever the pair is not already inside the offset.
        if (phi >= 0) EXPECT_GE(h.value(x[v], x[v]), 0.0);
      }
      if (side_share >= 0.0) share_sum += side_share, ++sides_movable;
    }
    // Both sides movable: their shares split the whole gap.
    if (sides_movable == 2 && phi != 0.0) EXPECT_NEAR(share_sum, 1.0, 1e-12);
  }
  for (Index v = 0; v < s.topo.num_vertices(); ++v)
    EXPECT_EQ(cursor[v], d.regions.row_start[v + 1]) << "vertex " << v << " has planes no contact explains";
}

TEST_P(NarrowPhaseScenes, DeterministicForAnyThreadCountAndBroadPhase) {
  const test::TestScene s = scene();
  Positions x = s.x;
  perturb(x, 3, 0.003);
  std::vector<Detection> results;
  for (const auto& name : broad_phase_names())
    for (int threads : {1, 2}) {
      set_thread_count(threads);
      CollisionDetector det(s.topo, s.x, kParams, make_broad_phase(name));
      results.push_back(run(det, x, s.inv_mass));
    }
  set_thread_count(0);
  // Planes of a vertex as a sorted list, for comparisons across broad phases (which may report
  // the candidates, hence the contacts and each vertex's planes, in another order).
  auto plane_sets = [&](const Detection& d) {
    std::vector<std::vector<std::array<double, 4>>> sets(static_cast<size_t>(s.topo.num_vertices()));
    for (Index v = 0; v < s.topo.num_vertices(); ++v) {
      for (const HalfSpace& h : d.regions.of(v)) sets[v].push_back({h.n.x(), h.n.y(), h.n.z(), h.d});
      std::sort(sets[v].begin(), sets[v].end());
    }
    return sets;
  };
  auto names_of = [](const Detection& d) {
    std::vector<SubPairName> names;
    for (const auto& c : d.contacts) names.push_back(name_of(c));
    return names;
  };
  const auto ref_sets = plane_sets(results.front());
  auto ref_names = names_of(results.front());
  std::sort(ref_names.begin(), ref_names.end());
  for (size_t i = 0; i < results.size(); ++i) {
    const Detection& d = results[i];
    if (i % 2 == 1) {
      // One broad phase at 1 and 2 threads: bit-identical regions and contact lists.
      const Detection& one = results[i - 1];
      EXPECT_EQ(d.regions.row_start, one.regions.row_start) << "run " << i;
      ASSERT_EQ(d.regions.total(), one.regions.total()) << "run " << i;
      for (size_t k = 0; k < d.regions.total(); ++k) {
        EXPECT_EQ(d.regions.plane(k).n, one.regions.plane(k).n);
        EXPECT_EQ(d.regions.plane(k).d, one.regions.plane(k).d);
      }
      EXPECT_EQ(names_of(d), names_of(one)) << "contact order depends on the thread count";
    }
    // Across broad phases: the same planes per vertex and the same contacts, as sets.
    EXPECT_EQ(d.regions.row_start, results.front().regions.row_start) << "run " << i;
    EXPECT_TRUE(plane_sets(d) == ref_sets) << "run " << i;
    auto names = names_of(d);
    std::sort(names.begin(), names.end());
    EXPECT_EQ(names, ref_names) << "run " << i;
  }
}

// The kept sub-pair list (set_reuse_skin): every pass equals a fresh pass bit for bit, contacts
// in the same order, on passes that reuse the list and passes that rebuild it, with every broad
// phase; and the contacts equal the all-pairs loop. Small moves reuse, a large one rebuilds.
TEST_P(NarrowPhaseScenes, ReusedListGivesTheFreshPassExactly) {
  const test::TestScene s = scene();
  const double skin = 2 * kR;
  for (const auto& name : broad_phase_names()) {
    CollisionDetector fresh(s.topo, s.x, kParams, make_broad_phase(name));
    CollisionDetector kept(s.topo, s.x, kParams, make_broad_phase(name));
    kept.set_reuse_skin(skin);
    EXPECT_EQ(kept.reuse_skin(), skin);
    Positions x = s.x;
    perturb(x, 70, 0.003);
    // Per pass: the move (radius of a random ball per vertex), whether the list is reused, and
    // whether the pass has a list. The first pass has no previous motion, so it does not list;
    // the second (no motion) lists; displacements since listing stay within skin / 2 = 0.005 for
    // two small moves (0.002 + 0.002); the large move (many vertices by more than 0.005) needs
    // the broad phase, and predicts no reuse, so it does not list; standing still lists again.
    struct Move {
      double radius;
      bool reused, listed;
    };
    const std::vector<Move> moves = {{0.0, false, false},  {0.0, false, true}, {0.002, true, true}, {0.002, true, true},
                                     {0.03, false, false}, {0.0, false, true}, {0.001, true, true}};
    for (size_t pass = 0; pass < moves.size(); ++pass) {
      if (moves[pass].radius > 0) perturb(x, 80 + pass, moves[pass].radius);
      const Detection a = run(fresh, x, s.inv_mass), b = run(kept, x, s.inv_mass);
      const std::string where = name + ", pass " + std::to_string(pass);
      EXPECT_FALSE(a.stats.reused) << where;
      EXPECT_EQ(a.stats.listed, 0) << where;
      EXPECT_EQ(b.stats.reused, moves[pass].reused) << where;
      EXPECT_EQ(b.stats.listed > 0, moves[pass].listed) << where;
      ASSERT_EQ(a.contacts.size(), b.contacts.size()) << where;
      for (size_t k = 0; k < a.contacts.size(); ++k) {
        const ContactPair &ca = a.contacts[k], &cb = b.contacts[k];
        ASSERT_TRUE(ca.kind == cb.kind && ca.v == cb.v && ca.w == cb.w && ca.n == cb.n && ca.distance == cb.distance &&
                    ca.offset == cb.offset)
            << where << ": contact " << k << " differs";
      }
      EXPECT_EQ(a.regions.row_start, b.regions.row_start) << where;
      ASSERT_EQ(a.regions.total(), b.regions.total()) << where;
      for (size_t k = 0; k < a.regions.total(); ++k)
        ASSERT_TRUE(a.regions.plane(k).n == b.regions.plane(k).n && a.regions.plane(k).d == b.regions.plane(k).d)
            << where << ": plane " << k;
      EXPECT_EQ(a.stats.pairs_within_range, b.stats.pairs_within_range) << where;
      EXPECT_EQ(a.stats.degenerate, b.stats.degenerate) << where;
      std::multiset<SubPairName> found;
      for (const auto& c : b.contacts) found.insert(name_of(c));
      EXPECT_EQ(found, brute_force_contacts(s, x, kept)) << where;
    }
  }
}

/// Whether two passes gave the same contacts in the same order and the same half-spaces, bit for bit.
::testing::AssertionResult same_detection(const Detection& a, const Detection& b) {
  if (a.contacts.size() != b.contacts.size())
    return ::testing::AssertionFailure() << a.contacts.size() << " contacts against " << b.contacts.size();
  for (size_t k = 0; k < a.contacts.size(); ++k) {
    const ContactPair &ca = a.contacts[k], &cb = b.contacts[k];
    if (!(ca.kind == cb.kind && ca.v == cb.v && ca.w == cb.w && ca.n == cb.n && ca.distance == cb.distance &&
          ca.offset == cb.offset))
      return ::testing::AssertionFailure() << "contact " << k << " differs";
  }
  if (a.regions.row_start != b.regions.row_start) return ::testing::AssertionFailure() << "plane counts differ";
  for (size_t k = 0; k < a.regions.total(); ++k)
    if (!(a.regions.plane(k).n == b.regions.plane(k).n && a.regions.plane(k).d == b.regions.plane(k).d))
      return ::testing::AssertionFailure() << "plane " << k << " differs";
  return ::testing::AssertionSuccess();
}

/// Passes of a random motion sequence: what the kept list did.
struct ReuseCounts {
  int reused = 0, shifted_reused = 0, rebuilt_after_large = 0, passes = 0;
};

/// The property of the kept list (docs/feasibility.md, "Reusing detection"): over a random
/// sequence of moves (common shifts of the whole scene or of everything but the obstacles, small
/// and large jitter, two vertices moved apart by exactly s/2 each or just under it from the
/// listing positions), every pass with the list equals a fresh pass bit for bit and the all-pairs
/// loop as a set, whether it reused the list or rebuilt it.
void check_reuse_sequence(const test::TestScene& s, std::uint64_t seed, ReuseCounts& counts) {
  const double skin = 2 * kR;
  CollisionDetector fresh(s.topo, s.x, kParams, make_broad_phase("bvh"));
  CollisionDetector kept(s.topo, s.x, kParams, make_broad_phase("bvh"));
  kept.set_reuse_skin(skin);
  auto g = test::rng(seed);
  std::uniform_int_distribution<int> pick(0, 6);
  std::uniform_int_distribution<Index> vertex(0, s.topo.num_vertices() - 1);
  Positions x = s.x, listed_x;
  for (int pass = 0; pass < 16; ++pass) {
    const int move = pass < 2 ? 0 : pick(g);
    const Vec3 shift = test::random_in_ball(g, 4 * skin);
    switch (move) {
      case 0:  // standing still (lists)
        break;
      case 1:  // the whole scene shifted by up to 2 s, jittered by s/10
      case 2:
        for (auto& p : x) p += shift + test::random_in_ball(g, 0.1 * skin);
        break;
      case 3:  // everything but the obstacles shifted by up to s/4 (they stay still)
        for (Index v = 0; v < s.topo.num_vertices(); ++v)
          if (s.topo.object_of_vertex(v).kind != ObjectKind::obstacle) x[v] += shift / 16;
        break;
      case 4:  // large jitter: beyond the skin
        perturb(x, seed * 100 + pass, 1.5 * skin);
        break;
      case 5:    // from the listing positions, two vertices apart by exactly s/2 each (a rebuild)
      case 6: {  // or by 0.49 s each (a reuse)
        if (listed_x.empty()) break;
        x = listed_x;
        const double step = move == 5 ? 0.5 * skin : 0.49 * skin;
        const Index a = vertex(g), b = (a + 1 + vertex(g) % (s.topo.num_vertices() - 1)) % s.topo.num_vertices();
        x[a].x() += step;
        x[b].x() -= step;
        break;
      }
    }
    const Detection a = run(fresh, x, s.inv_mass), b = run(kept, x, s.inv_mass);
    const std::string where =
        "seed " + std::to_string(seed) + ", pass " + std::to_string(pass) + ", move " + std::to_string(move);
    ASSERT_TRUE(same_detection(a, b)) << where << (b.stats.reused ? " (reused)" : " (fresh)");
    std::multiset<SubPairName> found;
    for (const auto& c : b.contacts) found.insert(name_of(c));
    ASSERT_EQ(found, brute_force_contacts(s, x, kept)) << where;
    if (move == 5 && !listed_x.empty()) EXPECT_FALSE(b.stats.reused) << where << ": s/2 each is not below s/2";
    if (move == 6 && !listed_x.empty()) EXPECT_TRUE(b.stats.reused) << where << ": 0.49 s each is";
    ++counts.passes;
    counts.reused += b.stats.reused;
    counts.shifted_reused += b.stats.reused && (move == 1 || move == 2);
    counts.rebuilt_after_large += !b.stats.reused && move == 4;
    if (!b.stats.reused && b.stats.listed > 0) listed_x = x;
    if (!b.stats.reused && b.stats.listed == 0) listed_x.clear();
  }
}

TEST_P(NarrowPhaseScenes, ReuseOverRandomMotionEqualsFreshDetection) {
  const test::TestScene s = scene();
  ReuseCounts counts;
  for (std::uint64_t seed = 1; seed <= 4; ++seed) {
    check_reuse_sequence(s, seed, counts);
    if (HasFatalFailure()) return;
  }
  // The sequences exercise both branches: reuse after whole-scene shifts larger than s/2 (a
  // translation moves no pair closer), rebuilds after the large jitter.
  EXPECT_GT(counts.shifted_reused, 0);
  EXPECT_GT(counts.rebuilt_after_large, 0);
  EXPECT_LT(counts.reused, counts.passes);
}

// Degenerate input for the same property: a zero-area triangle (collinear corners), parallel
// strand segments, coincident particles, and an obstacle at rest under them.
TEST(NarrowPhaseReuse, RandomMotionOverDegenerateInputEqualsFreshDetection) {
  test::ExpectWarnings expect_warnings;  // coincident particles and close segments at rest
  const test::TestScene s = test::degenerate_mixed_scene();
  ReuseCounts counts;
  for (std::uint64_t seed = 1; seed <= 8; ++seed) {
    check_reuse_sequence(s, seed, counts);
    if (HasFatalFailure()) return;
  }
  EXPECT_GT(counts.shifted_reused, 0);
  EXPECT_GT(counts.rebuilt_after_large, 0);
}

// The measure the reuse test reads, against its definition: objects that did not move are still,
// the spread is the largest |D - t| over the moving objects' vertices for the reported t, never
// above the largest |D| (t = 0), and a common shift has none.
TEST(NarrowPhaseReuse, ReuseMotionMatchesItsDefinition) {
  const test::TestScene s = mixed_scene();
  const Index nv = s.topo.num_vertices();
  auto g = test::rng(7);
  for (int trial = 0; trial < 20; ++trial) {
    Positions x = s.x;
    const Vec3 shift = test::random_in_ball(g, 0.1);
    const double jitter = trial % 4 == 0 ? 0.0 : 0.001 * trial;
    for (Index v = 0; v < nv; ++v)
      if (s.topo.object_of_vertex(v).kind != ObjectKind::obstacle || trial % 2 == 1)
        x[v] += shift + test::random_in_ball(g, jitter);
    std::vector<double> per_vertex(static_cast<size_t>(nv));
    const ReuseMotion m = measure_reuse_motion(s.topo, x, s.x, per_vertex.data());
    std::vector<std::uint8_t> moved(s.topo.objects.size(), 0);
    for (Index v = 0; v < nv; ++v) moved[s.topo.vertex_object[v]] |= !(x[v] == s.x[v]);
    for (size_t o = 0; o < moved.size(); ++o) ASSERT_EQ(m.still[o], !moved[o]) << "trial " << trial << ", object " << o;
    double spread = 0, largest = 0;
    for (Index v = 0; v < nv; ++v) {
      const bool moved_object = moved[s.topo.vertex_object[v]];
      ASSERT_EQ(per_vertex[v], (x[v] - s.x[v] - m.shift).norm());
      if (!moved_object) continue;
      spread = std::max(spread, (x[v] - s.x[v] - m.shift).norm());
      largest = std::max(largest, (x[v] - s.x[v]).norm());
    }
    EXPECT_EQ(m.spread, spread) << "trial " << trial;
    EXPECT_EQ(m.largest, largest) << "trial " << trial;
    EXPECT_LE(m.spread, m.largest) << "trial " << trial;
    EXPECT_LE(m.spread, std::sqrt(3.0) * jitter + 1e-12) << "trial " << trial << ": the shift is not removed";
  }
  Positions bad = s.x;
  bad[3].y() = std::nan("");
  EXPECT_EQ(measure_reuse_motion(s.topo, bad, s.x).spread, std::numeric_limits<double>::infinity());
  EXPECT_THROW(measure_reuse_motion(s.topo, Positions(2), s.x), Error);
}

// A still obstacle bounds the reuse of the moving objects by how far they were from it: far away,
// a shift of 3 s (straight toward it) keeps the list; near it, one of 1.5 s rebuilds (a pair left
// out at 2r + ξ + s may have come into range), and both equal a fresh pass.
TEST(NarrowPhaseReuse, StillObstacleBoundsReuseByItsDistance) {
  test::ExpectWarnings expect_warnings;  // the folded cloth's exclusions
  const double skin = 2 * kR;
  for (const double height : {0.2, 0.025}) {
    gen::TriMesh cloth = test::accordion_cloth(0.12, 10, 1, 0.011, 0.002);
    gen::TriMesh floor;
    floor.v = {Vec3(-0.2, -height, -0.2), Vec3(0.2, -height, -0.2), Vec3(-0.2, -height, 0.2), Vec3(0.2, -height, 0.2)};
    floor.f = {Vec3i(0, 2, 1), Vec3i(1, 2, 3)};
    const test::TestScene s = test::SceneBuilder()
                                  .mesh("cloth", ObjectKind::cloth, cloth)
                                  .mesh("floor", ObjectKind::obstacle, floor, 0.0)
                                  .finish();
    double lowest = std::numeric_limits<double>::infinity();
    for (const Vec3& p : cloth.v) lowest = std::min(lowest, p.y());
    CollisionDetector fresh(s.topo, s.x, kParams, make_broad_phase("bvh"));
    CollisionDetector kept(s.topo, s.x, kParams, make_broad_phase("bvh"));
    kept.set_reuse_skin(skin);
    kept.restart_reuse(0.0);
    Positions x = s.x;
    ASSERT_GT(run(kept, x, s.inv_mass).stats.listed, 0);
    run(fresh, x, s.inv_mass);
    const bool far = lowest + height > 2 * kR + kXi + 3 * skin;
    const double drop = far ? 3 * skin : 1.5 * skin;
    for (Index v = 0; v < static_cast<Index>(cloth.v.size()); ++v) x[v].y() -= drop;
    const Detection a = run(fresh, x, s.inv_mass), b = run(kept, x, s.inv_mass);
    EXPECT_EQ(b.stats.reused, far) << "floor at " << height;
    EXPECT_TRUE(same_detection(a, b)) << "floor at " << height;
  }
}

// A pass that lists at a rebuild (a frame start) builds the tree a pass without the list builds:
// over boxes grown by s/2 the centres (lo + hi) round differently, the many ties of flat grids
// split the other way and the contacts came out in another order (frames of the card stack
// differed in the last bits from the fifth frame on).
TEST(NarrowPhaseReuse, ListingAtARebuildKeepsTheFreshOrder) {
  gen::TriMesh lower = gen::grid(0.2, 0.2, 12, 12), upper = lower;
  for (auto& p : upper.v) p.y() += 0.012;
  Positions grains = gen::particle_block(6, 2, 6, 0.011);
  for (auto& p : grains) p += Vec3(0.0, 0.03, 0.0);
  const test::TestScene s = test::SceneBuilder()
                                .mesh("lower", ObjectKind::cloth, lower)
                                .mesh("upper", ObjectKind::cloth, upper)
                                .particles("grains", grains)
                                .finish();
  for (const auto& name : broad_phase_names()) {
    CollisionDetector fresh(s.topo, s.x, kParams, make_broad_phase(name));
    CollisionDetector kept(s.topo, s.x, kParams, make_broad_phase(name));
    kept.set_reuse_skin(2 * kR);
    Positions x = s.x;
    for (int frame = 0; frame < 3; ++frame) {
      if (frame > 0)
        for (auto& p : x) p.y() += 0.001;  // still flat: the ties stay
      fresh.rebuild_broad_phase();
      kept.rebuild_broad_phase();
      kept.restart_reuse(0.0);
      const Detection a = run(fresh, x, s.inv_mass), b = run(kept, x, s.inv_mass);
      ASSERT_GT(b.stats.listed, 0);
      EXPECT_TRUE(same_detection(a, b)) << name << ", frame " << frame;
    }
  }
}

// A whole scene shifted by more than s/2 (here 3 s) keeps the list: a translation brings no pair
// closer. (The rule before counted the shift itself and rebuilt.)
TEST_P(NarrowPhaseScenes, CommonShiftKeepsTheList) {
  const test::TestScene s = scene();
  const double skin = 2 * kR;
  CollisionDetector fresh(s.topo, s.x, kParams, make_broad_phase("bvh"));
  CollisionDetector kept(s.topo, s.x, kParams, make_broad_phase("bvh"));
  kept.set_reuse_skin(skin);
  Positions x = s.x;
  run(kept, x, s.inv_mass);
  ASSERT_GT(run(kept, x, s.inv_mass).stats.listed, 0);
  for (int pass = 0; pass < 3; ++pass) {
    for (auto& p : x) p += Vec3(3 * skin, -2 * skin, skin);
    const Detection a = run(fresh, x, s.inv_mass), b = run(kept, x, s.inv_mass);
    EXPECT_TRUE(b.stats.reused) << "pass " << pass;
    EXPECT_TRUE(same_detection(a, b)) << "pass " << pass;
  }
}

// rebuild_broad_phase(): a tree rebuilt over moved boxes finds exactly the contacts of the
// refitted one (its order may differ) and of the all-pairs loop, and each vertex keeps the same
// half-spaces; the request holds for one pass only.
TEST_P(NarrowPhaseScenes, RebuiltBroadPhaseFindsTheSameContacts) {
  const test::TestScene s = scene();
  for (const auto& name : broad_phase_names()) {
    CollisionDetector refit(s.topo, s.x, kParams, make_broad_phase(name));
    CollisionDetector rebuilt(s.topo, s.x, kParams, make_broad_phase(name));
    Positions x = s.x;
    for (int pass = 0; pass < 4; ++pass) {
      perturb(x, 120 + pass, 0.004 * pass);
      if (pass % 2 == 1) rebuilt.rebuild_broad_phase();
      const Detection a = run(refit, x, s.inv_mass), b = run(rebuilt, x, s.inv_mass);
      const std::string where = name + ", pass " + std::to_string(pass);
      std::multiset<SubPairName> fa, fb;
      for (const auto& c : a.contacts) fa.insert(name_of(c));
      for (const auto& c : b.contacts) fb.insert(name_of(c));
      EXPECT_EQ(fa, fb) << where;
      EXPECT_EQ(fb, brute_force_contacts(s, x, rebuilt)) << where;
      ASSERT_EQ(a.regions.row_start, b.regions.row_start) << where;
      for (Index v = 0; v < a.regions.num_vertices(); ++v) {
        auto planes = [](std::span<const HalfSpace> r) {
          std::vector<std::array<double, 4>> out;
          for (const HalfSpace& h : r) out.push_back({h.n.x(), h.n.y(), h.n.z(), h.d});
          std::sort(out.begin(), out.end());
          return out;
        };
        ASSERT_EQ(planes(a.regions.of(v)), planes(b.regions.of(v))) << where << ", vertex " << v;
      }
    }
    // A rebuild drops the kept list: the pass after it enumerates through the new tree.
    CollisionDetector kept(s.topo, s.x, kParams, make_broad_phase(name));
    kept.set_reuse_skin(2 * kR);
    EXPECT_FALSE(run(kept, x, s.inv_mass).stats.reused) << name;  // no previous motion: no list
    EXPECT_FALSE(run(kept, x, s.inv_mass).stats.reused) << name;  // lists
    EXPECT_TRUE(run(kept, x, s.inv_mass).stats.reused) << name;
    kept.rebuild_broad_phase();
    EXPECT_FALSE(run(kept, x, s.inv_mass).stats.reused) << name;  // rebuilt, lists again
    EXPECT_TRUE(run(kept, x, s.inv_mass).stats.reused) << name;
  }
}

// A changed inverse mass (a vertex pinned between passes) invalidates the list: the pass rebuilds
// and still equals a fresh one. Bad skins are refused; a skin of 0 turns reuse off.
TEST(NarrowPhaseReuse, MassChangesRebuildAndBadSkinsAreRefused) {
  test::ExpectWarnings expect_warnings;  // the folded cloth's exclusions
  const test::TestScene s = folded_cloth_scene();
  CollisionDetector fresh(s.topo, s.x, kParams, make_broad_phase("bvh"));
  CollisionDetector kept(s.topo, s.x, kParams, make_broad_phase("bvh"));
  kept.set_reuse_skin(2 * kR);
  std::vector<double> w = s.inv_mass;
  Positions x = s.x;
  perturb(x, 5, 0.003);
  EXPECT_FALSE(run(kept, x, w).stats.reused);  // no previous pass: no list
  EXPECT_FALSE(run(kept, x, w).stats.reused);  // lists
  EXPECT_TRUE(run(kept, x, w).stats.reused);
  for (Index v = 0; v < static_cast<Index>(w.size()); v += 3) w[v] = 0.0;
  const Detection a = run(fresh, x, w), b = run(kept, x, w);
  EXPECT_FALSE(b.stats.reused);
  std::vector<SubPairName> na, nb;
  for (const auto& c : a.contacts) na.push_back(name_of(c));
  for (const auto& c : b.contacts) nb.push_back(name_of(c));
  EXPECT_EQ(na, nb);
  EXPECT_EQ(a.regions.row_start, b.regions.row_start);
  kept.invalidate_reuse();
  EXPECT_FALSE(run(kept, x, w).stats.reused);
  // restart_reuse: the given step decides whether the next pass lists, not the previous pass.
  kept.restart_reuse(0.0);
  Detection d = run(kept, x, w);
  EXPECT_FALSE(d.stats.reused);
  EXPECT_GT(d.stats.listed, 0);
  EXPECT_TRUE(run(kept, x, w).stats.reused);
  kept.restart_reuse(kR);  // a last step of r > skin / 2: no list
  d = run(kept, x, w);
  EXPECT_FALSE(d.stats.reused);
  EXPECT_EQ(d.stats.listed, 0);
  EXPECT_GT(run(kept, x, w).stats.listed, 0);  // then judged by the previous pass again
  EXPECT_THROW(kept.set_reuse_skin(-1e-3), Error);
  EXPECT_THROW(kept.set_reuse_skin(std::nan("")), Error);
  EXPECT_THROW(kept.set_reuse_skin(std::numeric_limits<double>::infinity()), Error);
  kept.set_reuse_skin(0.0);
  run(kept, x, w);
  const Detection off = run(kept, x, w);
  EXPECT_FALSE(off.stats.reused);
  EXPECT_EQ(off.stats.listed, 0);
}

std::string scene_name(const ::testing::TestParamInfo<int>& info) {
  static const char* const names[] = {"folded_cloth", "strands", "mixed"};
  return names[info.param];
}
INSTANTIATE_TEST_SUITE_P(Collision, NarrowPhaseScenes, ::testing::Values(0, 1, 2), scene_name);

TEST(NarrowPhaseExclusions, SubPairsCloserThanOffsetInitially) {
  // Fine cloth: 2.5 mm edges, far below ξ = 10 mm (design clarification 5): every sub-pair closer
  // than ξ lies within 2ξ along the sheet, so all are adjacent: none is excluded (that hid
  // self-intersections, issue #39), each keeps its rest distance less the margin as a fixed offset.
  test::ExpectWarnings expect;
  const test::TestScene s =
      test::SceneBuilder().mesh("cloth", ObjectKind::cloth, test::accordion_cloth(0.06, 24, 1, 0.011, 0.002)).finish();
  CollisionDetector det(s.topo, s.x, kParams, make_broad_phase("bvh"));
  std::map<std::pair<int, std::pair<Index, Index>>, double> close;
  for_each_sub_pair(s, s.x, [&](ContactKind kind, Index a, Index b, auto&&, auto&&, auto&&, auto&&, double dist_sq) {
    if (dist_sq < kXi * kXi) close[{static_cast<int>(kind), {a, b}}] = std::sqrt(dist_sq);
  });
  ASSERT_FALSE(close.empty());
  EXPECT_EQ(det.num_initially_intersecting(), 0);
  EXPECT_EQ(det.num_excluded(), 0);
  EXPECT_EQ(det.initial_proximity().adjacent_kept, static_cast<Index>(close.size()));
  for (const auto& [kab, d0] : close) {
    const auto kind = static_cast<ContactKind>(kab.first);
    EXPECT_FALSE(det.is_excluded(kind, kab.second.first, kab.second.second));
    EXPECT_DOUBLE_EQ(det.pair_offset(kind, kab.second.first, kab.second.second), (1.0 - kInitialOffsetMargin) * d0);
  }

  const Detection d = run(det, s.x, s.inv_mass);
  EXPECT_EQ(d.stats.excluded_initial, 0);
  for (const auto& c : d.contacts) EXPECT_GE(c.distance, c.offset) << "the rest configuration is feasible";
  for (const HalfSpace& h : d.regions.rows()) EXPECT_GE(h.d, 0.0);
}

TEST(NarrowPhaseExclusions, PrimitivesIntersectingInitially) {
  // Triangle b pierces triangle a 13 mm from a's edges (between ξ and 2r + ξ), with all vertices
  // far away; a strand segment pierces a elsewhere. Every sub-pair of both primitive pairs is
  // excluded, so the crossing edges never produce (inverted) half-spaces.
  test::ExpectWarnings expect;
  gen::TriMesh a{{Vec3(-1, 0, -1), Vec3(1, 0, -1), Vec3(0, 0, 1)}, {Vec3i(0, 1, 2)}};
  gen::TriMesh b{{Vec3(0, -1, 0.97), Vec3(0, 1, 0.97), Vec3(-0.5, 0.2, 2)}, {Vec3i(0, 1, 2)}};
  gen::PolylineSet pin;
  pin.v = {Vec3(0.3, -0.5, -0.2), Vec3(0.3, 0.5, -0.2)};
  pin.lines = {{0, 1}};
  const test::TestScene s =
      test::SceneBuilder().mesh("a", ObjectKind::cloth, a).mesh("b", ObjectKind::cloth, b).strands("pin", pin).finish();
  for (const auto& name : broad_phase_names()) {
    CollisionDetector det(s.topo, s.x, kParams, make_broad_phase(name));
    EXPECT_EQ(det.num_initially_intersecting(), 2) << name;
    const Detection d = run(det, s.x, s.inv_mass);
    EXPECT_GT(d.stats.excluded_initial, 0) << name;
    EXPECT_TRUE(d.contacts.empty()) << name;
    // Without the exclusions the crossing edge of b is within range of a's edges.
    Index in_range = 0;
    for_each_sub_pair(s, s.x, [&](ContactKind, Index, Index, auto&&, auto&&, auto&&, auto&&, double dist_sq) {
      in_range += dist_sq < (2 * kR + kXi) * (2 * kR + kXi) ? 1 : 0;
    });
    EXPECT_GT(in_range, 0);
  }
}

TEST(NarrowPhase, RejectsNonFinitePositions) {
  test::ExpectWarnings expect;  // the folded cloth's edges are shorter than ξ
  const test::TestScene s = folded_cloth_scene();
  CollisionDetector det(s.topo, s.x, kParams, make_broad_phase("bvh"));
  Positions x = s.x;
  x[11].z() = std::numeric_limits<double>::quiet_NaN();
  Detection d;
  EXPECT_THROW(det.detect(x, s.inv_mass, d.regions, d.contacts, d.stats), Error);
  EXPECT_THROW(det.detect(s.x, std::vector<double>(3, 1.0), d.regions, d.contacts, d.stats), Error);
}

// Issue 13: a 40,962-vertex static sphere (the size of the paper's bunny) 10 m from a cloth adds no
// broad-phase candidate: obstacle-obstacle pairs can never change and are never enumerated. The
// reference is the same cloth without the obstacle; without the fixed flags the sphere's boxes
// overlap each other far more often than the cloth's.
TEST(CollisionDetector, StaticObstacleFarAwayAddsNoCandidates) {
  const gen::TriMesh cloth = test::accordion_cloth(0.6, 30, 2, 0.015, 0.004);  // edges above ξ: no warning
  gen::TriMesh ball = gen::sphere(0.5, 6);
  ASSERT_EQ(ball.v.size(), 40962u);
  for (auto& p : ball.v) p += Vec3(10.0, 0, 0);
  const test::TestScene alone = test::SceneBuilder().mesh("cloth", ObjectKind::cloth, cloth).finish();
  const test::TestScene both = test::SceneBuilder()
                                   .mesh("cloth", ObjectKind::cloth, cloth)
                                   .mesh("ball", ObjectKind::obstacle, ball, 0.0)
                                   .finish();
  auto run = [](const test::TestScene& s, DetectionStats& stats) {
    CollisionDetector det(s.topo, s.x, kParams, make_broad_phase("bvh"));
    RegionSet regions;
    std::vector<ContactPair> contacts;
    det.detect(s.x, s.inv_mass, regions, contacts, stats);
    return contacts.size();
  };
  DetectionStats st_alone, st_both;
  const size_t contacts_alone = run(alone, st_alone), contacts_both = run(both, st_both);
  EXPECT_GT(st_alone.candidates, 0);
  EXPECT_EQ(st_both.candidates, st_alone.candidates);
  EXPECT_EQ(contacts_both, contacts_alone);
  EXPECT_EQ(st_both.constraints, st_alone.constraints);

  // Without the flags the sphere's own boxes overlap in the millions (why this matters).
  const CollisionPrimitives prims = build_collision_primitives(both.topo);
  std::vector<AABB> boxes;
  compute_primitive_boxes(prims, both.topo, both.x, box_inflation(kR, kXi, kDelta), boxes);
  auto bp = make_broad_phase("bvh");
  bp->build(boxes);
  std::vector<IndexPair> all;
  bp->query_pairs(all);
  EXPECT_GT(static_cast<Index>(all.size()), 10 * st_alone.candidates);
}

}  // namespace
}  // namespace ccfr
