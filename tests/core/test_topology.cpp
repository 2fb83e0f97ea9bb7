#include <gtest/gtest.h>

#include <algorithm>
#include <set>

#include "ccfr/core/csr.hpp"
#include "ccfr/core/error.hpp"
#include "ccfr/core/parallel.hpp"
#include "ccfr/core/topology.hpp"
#include "test_support.hpp"

using namespace ccfr;

TEST(Topology, TwoObjectsShareNothingAndEdgesAreUnique) {
  TopologyBuilder b;
  // A quad as two triangles, then a 3-vertex strand.
  b.add_object("quad", ObjectKind::cloth, 4, {{0, 1, 2}, {0, 2, 3}});
  b.add_object("hair", ObjectKind::strand, 3, {}, {}, {{0, 1, 2}});
  b.add_object("dust", ObjectKind::particles, 2);
  const Topology t = b.finish();
  EXPECT_EQ(t.num_vertices(), 9);
  EXPECT_EQ(t.num_faces(), 2);
  ASSERT_EQ(t.num_edges(), 5 + 2);  // quad: 4 boundary + 1 diagonal; strand: 2 segments
  std::set<std::pair<Index, Index>> seen;
  for (const auto& e : t.edges) {
    EXPECT_LT(e[0], e[1]);
    EXPECT_TRUE(seen.insert({e[0], e[1]}).second);
  }
  EXPECT_EQ(t.objects[1].vertex_begin, 4);
  EXPECT_EQ(t.polylines.rows(), 1);
  EXPECT_EQ(t.polylines.row(0)[0], 4);
  EXPECT_EQ(t.edge_object.back(), 1);
  EXPECT_EQ(t.vertex_object[7], 2);
  // face_edges name the right vertex pairs.
  for (Index f = 0; f < t.num_faces(); ++f)
    for (int k = 0; k < 3; ++k) {
      const Vec2i e = t.edges[t.face_edges[f][k]];
      const Index a = t.faces[f][k], c = t.faces[f][(k + 1) % 3];
      EXPECT_EQ(e[0], std::min(a, c));
      EXPECT_EQ(e[1], std::max(a, c));
    }
}

TEST(Topology, IncidenceMatchesBruteForce) {
  TopologyBuilder b;
  b.add_object("fan", ObjectKind::cloth, 6, {{0, 1, 2}, {0, 2, 3}, {0, 3, 4}, {0, 4, 5}});
  const Topology t = b.finish();
  for (Index v = 0; v < t.num_vertices(); ++v) {
    std::vector<Index> expect;
    for (Index f = 0; f < t.num_faces(); ++f)
      if ((t.faces[f].array() == v).any()) expect.push_back(f);
    auto row = t.vertex_faces.row(v);
    EXPECT_EQ(std::vector<Index>(row.begin(), row.end()), expect) << "vertex " << v;
    std::vector<Index> expect_e;
    for (Index e = 0; e < t.num_edges(); ++e)
      if (t.edges[e][0] == v || t.edges[e][1] == v) expect_e.push_back(e);
    auto erow = t.vertex_edges.row(v);
    EXPECT_EQ(std::vector<Index>(erow.begin(), erow.end()), expect_e);
  }
}

TEST(Topology, OutOfRangeIndexIsRejected) {
  TopologyBuilder b;
  EXPECT_THROW(b.add_object("bad", ObjectKind::cloth, 3, {{0, 1, 3}}), std::invalid_argument);
}

TEST(Topology, TetBoundaryOfOneTetIsOutward) {
  const std::vector<Vec4i> tets{{0, 1, 2, 3}};
  const Positions x{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  const auto faces = tet_boundary(tets);
  ASSERT_EQ(faces.size(), 4u);
  const Vec3 centroid = 0.25 * (x[0] + x[1] + x[2] + x[3]);
  for (const auto& f : faces) {
    const Vec3 n = (x[f[1]] - x[f[0]]).cross(x[f[2]] - x[f[0]]);
    EXPECT_GT(n.dot(x[f[0]] - centroid), 0.0);
  }
}

TEST(Topology, TetSolidObjectGetsItsBoundaryFaces) {
  TopologyBuilder b;
  b.add_object("pad", ObjectKind::cloth, 3, {{0, 1, 2}});
  // Two tets sharing face (1,2,3): boundary has 6 faces.
  b.add_object("solid", ObjectKind::tet_solid, 5, {}, {{0, 1, 2, 3}, {4, 1, 3, 2}});
  const Topology t = b.finish();
  EXPECT_EQ(t.objects[1].face_end - t.objects[1].face_begin, 6);
  for (Index f = t.objects[1].face_begin; f < t.objects[1].face_end; ++f)
    for (int k = 0; k < 3; ++k) EXPECT_GE(t.faces[f][k], 3);
}

TEST(Kinds, RoundTripNames) {
  for (auto name : object_kind_names()) {
    auto k = object_kind_from_string(name);
    ASSERT_TRUE(k.has_value());
    EXPECT_EQ(to_string(*k), name);
  }
  EXPECT_FALSE(object_kind_from_string("clothe").has_value());
}

TEST(Parallel, ChunksCoverTheRangeOnceForAnyThreadCount) {
  for (int threads : {1, 2}) {
    set_thread_count(threads);
    EXPECT_EQ(thread_count(), threads);
    for (Index n : {0, 1, 7, 1000, 100003}) {
      std::vector<int> hits(static_cast<size_t>(n), 0);
      const Index chunks = default_chunk_count(n);
      std::vector<std::pair<Index, Index>> bounds(static_cast<size_t>(std::max<Index>(chunks, 1)), {-1, -1});
      parallel_chunks(n, chunks, [&](Index c, Index b, Index e) {
        bounds[c] = {b, e};
        for (Index i = b; i < e; ++i) ++hits[i];
      });
      EXPECT_TRUE(std::all_of(hits.begin(), hits.end(), [](int h) { return h == 1; }));
      // Fixed boundaries: chunk c starts where c-1 ends.
      for (Index c = 1; c < chunks && n > 0; ++c) EXPECT_EQ(bounds[c].first, bounds[c - 1].second);
      std::vector<int> hits2(static_cast<size_t>(n), 0);
      parallel_for(
          n,
          [&](Index b, Index e) {
            for (Index i = b; i < e; ++i) ++hits2[i];
          },
          64);
      EXPECT_TRUE(std::all_of(hits2.begin(), hits2.end(), [](int h) { return h == 1; }));
    }
  }
  set_thread_count(0);
}

TEST(Errors, ConfigErrorNamesFileKeyAndLine) {
  const ConfigError e("scene.yaml", "contact.radius", 12, "must be > 0");
  EXPECT_STREQ(e.what(), "scene.yaml:12: 'contact.radius': must be > 0");
  const ConfigError no_line("cmd", "time.fps", 0, "bad");
  EXPECT_STREQ(no_line.what(), "cmd: 'time.fps': bad");
  const NumericalError n(3, 17, "xpbd");
  EXPECT_NE(std::string(n.what()).find("frame 3"), std::string::npos);
  EXPECT_NE(std::string(n.what()).find("vertex 17"), std::string::npos);
}
