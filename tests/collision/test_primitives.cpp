// The primitive set: kinds, ranges, representatives (each vertex and edge owned exactly once).
#include <gtest/gtest.h>

#include "ccfr/collision/primitives.hpp"
#include "scenes.hpp"
#include "test_support.hpp"

namespace ccfr {
namespace {

TEST(CollisionPrimitives, LayoutAndRepresentatives) {
  gen::PolylineSet hair = gen::straight_strands(3, 5, 0.1, 0.05);
  hair.lines.push_back({static_cast<Index>(hair.v.size())});  // a one-vertex strand collides as a point
  hair.v.emplace_back(0.3, 0.3, 0.3);
  const test::TestScene s = test::SceneBuilder()
                                .mesh("cloth", ObjectKind::cloth, gen::grid(0.2, 0.2, 4, 3))
                                .strands("hair", hair)
                                .particles("dust", gen::particle_block(2, 2, 1, 0.1))
                                .mesh("crate", ObjectKind::rigid, gen::box(Vec3::Ones()))
                                .tets("jelly", gen::tet_box(Vec3::Ones(), Vec3i(2, 2, 2)))
                                .finish();
  const CollisionPrimitives p = build_collision_primitives(s.topo);
  EXPECT_EQ(p.num_triangles, s.topo.num_faces());
  EXPECT_EQ(p.num_edges, 3 * 4);
  EXPECT_EQ(p.num_points, 4 + 1);
  EXPECT_EQ(p.size(), p.num_triangles + p.num_edges + p.num_points);
  for (Index i = 0; i < p.num_edges; ++i) {
    EXPECT_EQ(s.topo.objects[s.topo.edge_object[p.edge_ids[i]]].kind, ObjectKind::strand);
    EXPECT_EQ(p.kind(p.num_triangles + i), PrimitiveKind::edge);
  }
  EXPECT_EQ(p.kind(p.size() - 1), PrimitiveKind::point);

  // Every surface and strand vertex, and every edge, has exactly one representative.
  std::vector<int> vertex_owner(static_cast<size_t>(s.topo.num_vertices()), 0);
  std::vector<int> edge_owner(static_cast<size_t>(s.topo.num_edges()), 0);
  for (Index f = 0; f < p.num_triangles; ++f)
    for (int k = 0; k < 3; ++k) {
      if (p.face_owns[f] >> k & 1) ++vertex_owner[s.topo.faces[f][k]];
      if (p.face_owns[f] >> (3 + k) & 1) ++edge_owner[s.topo.face_edges[f][k]];
    }
  for (Index i = 0; i < p.num_edges; ++i) {
    ++edge_owner[p.edge_ids[i]];
    for (int k = 0; k < 2; ++k)
      if (p.segment_owns[i] >> k & 1) ++vertex_owner[s.topo.edges[p.edge_ids[i]][k]];
  }
  for (Index v : p.point_ids) ++vertex_owner[v];
  for (int c : edge_owner) EXPECT_EQ(c, 1);
  for (Index v = 0; v < s.topo.num_vertices(); ++v) {
    const bool on_surface = s.topo.vertex_faces.row(v).size() > 0;
    const bool tet_interior = s.topo.object_of_vertex(v).kind == ObjectKind::tet_solid && !on_surface;
    EXPECT_EQ(vertex_owner[v], tet_interior ? 0 : 1) << "vertex " << v;
  }
  for (Index f = 0; f < p.num_triangles; ++f)
    EXPECT_EQ(p.face_no_self[f] != 0, s.topo.objects[s.topo.face_object[f]].kind == ObjectKind::rigid);
}

TEST(CollisionPrimitives, BoxesAreInflatedHulls) {
  const test::TestScene s = test::SceneBuilder()
                                .mesh("cloth", ObjectKind::cloth, gen::grid(0.2, 0.2, 2, 2))
                                .particles("p", {Vec3(1, 2, 3)})
                                .finish();
  const CollisionPrimitives p = build_collision_primitives(s.topo);
  EXPECT_DOUBLE_EQ(box_inflation(0.005, 0.01, 0.0005), 0.005 + 0.005 + 0.00025);
  std::vector<AABB> boxes;
  compute_primitive_boxes(p, s.topo, s.x, 0.5, boxes);
  ASSERT_EQ(static_cast<Index>(boxes.size()), p.size());
  for (Index f = 0; f < p.num_triangles; ++f) {
    AABB b = AABB::of(s.x[s.topo.faces[f][0]], s.x[s.topo.faces[f][1]], s.x[s.topo.faces[f][2]]);
    b.inflate(0.5);
    EXPECT_EQ(boxes[f].lo, b.lo);
    EXPECT_EQ(boxes[f].hi, b.hi);
  }
  EXPECT_EQ(boxes.back().lo, Vec3(0.5, 1.5, 2.5));
  Positions bad = s.x;
  bad[4].y() = std::numeric_limits<double>::quiet_NaN();
  compute_primitive_boxes(p, s.topo, bad, 0.5, boxes);
  for (Index f = 0; f < p.num_triangles; ++f)
    if (s.topo.faces[f][0] == 4 || s.topo.faces[f][1] == 4 || s.topo.faces[f][2] == 4)
      EXPECT_FALSE(boxes[f].lo.allFinite() && boxes[f].hi.allFinite());
}

}  // namespace
}  // namespace ccfr
