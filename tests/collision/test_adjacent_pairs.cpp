// Meshes finer than ξ (issue #39, item 3 and design clarification 5): neighbours on the mesh that
// start closer than ξ keep contact with their rest distance less the margin, fixed for the run,
// instead of being excluded (which let a held-back soft knot intersect itself unseen). And a tet
// solid collides through its boundary only. Independent answers: brute-force distances over all
// vertex-face pairs, the boundary faces counted by hand.
#include <gtest/gtest.h>

#include <algorithm>
#include <map>
#include <set>

#include "ccfr/collision/collision_detector.hpp"
#include "ccfr/geometry/distance.hpp"
#include "ccfr/geometry/generators.hpp"
#include "test_support.hpp"

using namespace ccfr;

namespace {

struct Sheet {
  Topology topo;
  Positions x;
};

/// A 10 mm cloth of 1 mm cells: with ξ = 2 mm, vertices and faces a ring or two apart start
/// closer than ξ (in the plane) and are joined by paths shorter than 2ξ along the mesh.
Sheet fine_sheet() {
  const auto g = gen::grid(0.01, 0.01, 10, 10);
  TopologyBuilder tb;
  tb.add_object("sheet", ObjectKind::cloth, static_cast<Index>(g.v.size()), g.f);
  return {tb.finish(), g.v};
}

}  // namespace

TEST(AdjacentPairs, KeepTheirRestDistanceLessTheMarginAsAFixedOffset) {
  const Sheet s = fine_sheet();
  const double xi = 0.002;
  test::ExpectWarnings expect;  // the fine mesh is reported at warning level
  CollisionDetector det(s.topo, s.x, {0.001, xi, 0.0}, make_broad_phase("bvh"));
  const InitialProximity& ip = det.initial_proximity();
  // Brute force: every vertex-face pair sharing no vertex and closer than ξ at rest.
  Index close = 0;
  for (Index v = 0; v < s.topo.num_vertices(); ++v)
    for (Index f = 0; f < s.topo.num_faces(); ++f) {
      const Vec3i& t = s.topo.faces[f];
      if (t[0] == v || t[1] == v || t[2] == v) continue;
      const double d = std::sqrt(point_triangle(s.x[v], s.x[t[0]], s.x[t[1]], s.x[t[2]]).distance_sq);
      if (!(d < xi)) {
        EXPECT_EQ(det.pair_offset(ContactKind::vf, v, f), xi);
        continue;
      }
      ++close;
      EXPECT_DOUBLE_EQ(det.pair_offset(ContactKind::vf, v, f), (1.0 - kInitialOffsetMargin) * d) << v << " " << f;
    }
  EXPECT_GT(close, 100);
  EXPECT_GE(ip.adjacent_kept, close);  // plus the edge-edge pairs
  EXPECT_EQ(ip.reduced_offset, 0);     // everything close here is a neighbour
}

TEST(AdjacentPairs, AFoldThroughANeighbourIsSeenAndItsOffsetNeverRises) {
  const Sheet s = fine_sheet();
  const double xi = 0.002;
  test::ExpectWarnings expect;
  CollisionDetector det(s.topo, s.x, {0.001, xi, 0.0}, make_broad_phase("bvh"));
  // Vertex 12 (row 1, column 1) and a face diagonally across the next cell: a neighbour on the mesh.
  const Index v = 12;
  Index face = -1;
  double d0 = 0.0;
  for (Index f = 0; f < s.topo.num_faces() && face < 0; ++f) {
    const Vec3i& t = s.topo.faces[f];
    if (t[0] == v || t[1] == v || t[2] == v) continue;
    const double d = std::sqrt(point_triangle(s.x[v], s.x[t[0]], s.x[t[1]], s.x[t[2]]).distance_sq);
    if (d > 0.0011 && d < 0.0019) face = f, d0 = d;
  }
  ASSERT_GE(face, 0);
  // Stretch the sheet apart around the pair first (the offset of a non-adjacent pair would rise
  // with it), then bring the vertex right onto the face's plane next to it.
  Positions x = s.x;
  for (auto& p : x) p *= 1.5;
  std::vector<double> w(x.size(), 1.0);
  RegionSet regions;
  std::vector<ContactPair> contacts;
  DetectionStats stats;
  det.detect(x, w, regions, contacts, stats);
  EXPECT_EQ(stats.excluded_initial, 0);
  EXPECT_DOUBLE_EQ(det.pair_offset(ContactKind::vf, v, face), (1.0 - kInitialOffsetMargin) * d0)
      << "an adjacent pair's offset must not rise as the mesh stretches";
  x = s.x;
  const Vec3i& t = s.topo.faces[face];
  const Vec3 centre = (x[t[0]] + x[t[1]] + x[t[2]]) / 3.0;
  x[v] = x[v] + 0.7 * (centre - x[v]) + Vec3(0, 0.0002, 0);  // folded over toward the face
  det.detect(x, w, regions, contacts, stats);
  const auto it = std::find_if(contacts.begin(), contacts.end(), [&](const ContactPair& c) {
    return c.kind == ContactKind::vf && c.v[0] == v && c.v[1] == t[0] && c.v[2] == t[1] && c.v[3] == t[2];
  });
  ASSERT_NE(it, contacts.end()) << "the neighbour pair is detected";
  EXPECT_DOUBLE_EQ(it->offset, (1.0 - kInitialOffsetMargin) * d0);
  EXPECT_TRUE(it->neighbours);          // no repulsion: their distance is the material's business
  EXPECT_LT(it->distance, it->offset);  // inside its offset: the recount sees it
}

TEST(AdjacentPairs, TetSolidCollidesThroughItsBoundaryOnly) {
  // 2 x 2 x 2 cells: 27 vertices, one of them interior; 6 faces x 8 boundary triangles.
  const auto box = gen::tet_box(Vec3(1, 1, 1), Vec3i(2, 2, 2));
  TopologyBuilder tb;
  tb.add_object("box", ObjectKind::tet_solid, static_cast<Index>(box.v.size()), {}, box.t);
  const Topology topo = tb.finish();
  const CollisionPrimitives p = build_collision_primitives(topo);
  EXPECT_EQ(p.num_triangles, 48);
  EXPECT_EQ(p.num_edges, 0);   // no interior tet edge becomes a segment
  EXPECT_EQ(p.num_points, 0);  // and no interior vertex a point
  std::set<Index> on_surface;
  for (const Vec3i& f : topo.faces)
    for (int k = 0; k < 3; ++k) on_surface.insert(f[k]);
  EXPECT_EQ(on_surface.size(), 26u);
  for (Index v : on_surface) EXPECT_GT(box.v[v].cwiseAbs().maxCoeff(), 0.5 - 1e-12);  // all on the box's faces
}
