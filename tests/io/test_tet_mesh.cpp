// Tet meshes from files (TetGen .node/.ele, Gmsh .msh v2 and v4) and closed OBJ surfaces filled by
// the real tetgen program, against known volumes; malformed files get one error naming the line.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <regex>

#include "ccfr/core/error.hpp"
#include "ccfr/core/process.hpp"
#include "ccfr/geometry/generators.hpp"
#include "ccfr/io/scene_loader.hpp"
#include "ccfr/io/tet_mesh.hpp"
#include "cli_support.hpp"

using namespace ccfr;
namespace fs = std::filesystem;

namespace {

// A 2 x 3 x 4 box cut into 5 tets by hand: four corner tets (abc/6 each) and the middle one (abc/3).
// Nodes are numbered from 1 as TetGen's own output may be; two tets are listed inverted.
const char* kNode = R"(# box 2 x 3 x 4
8 3 0 1
1  0 0 0  1
2  2 0 0  1
3  2 3 0  1
4  0 3 0  1
5  0 0 4  1
6  2 0 4  1
7  2 3 4  1
8  0 3 4  1
)";
const char* kEle = R"(5 4 0
1  1 2 4 5
2  2 3 4 7
3  2 6 5 7   # inverted
4  4 5 7 8
5  2 5 4 7   # inverted
)";

// The same box in Gmsh 2.2 (with a triangle element and an unused node, both ignored).
const char* kMsh2 = R"($MeshFormat
2.2 0 8
$EndMeshFormat
$Nodes
9
1 0 0 0
2 2 0 0
3 2 3 0
4 0 3 0
5 0 0 4
6 2 0 4
7 2 3 4
8 0 3 4
9 5 5 5
$EndNodes
$Elements
6
1 2 2 0 1 1 2 3
2 4 2 0 1 1 2 4 5
3 4 2 0 1 2 3 4 7
4 4 2 0 1 2 5 6 7
5 4 2 0 1 4 5 7 8
6 4 2 0 1 2 4 5 7
$EndElements
)";

// And in Gmsh 4.1: node tags in blocks, then coordinates; element blocks by type.
const char* kMsh4 = R"($MeshFormat
4.1 0 8
$EndMeshFormat
$Entities
0 0 0 1
1 0 0 0 2 3 4 0
$EndEntities
$Nodes
2 8 1 8
3 1 0 5
1
2
3
4
5
0 0 0
2 0 0
2 3 0
0 3 0
0 0 4
3 1 0 3
6
7
8
2 0 4
2 3 4
0 3 4
$EndNodes
$Elements
2 6 1 6
2 1 2 1
1 1 2 3
3 1 4 5
2 1 2 4 5
3 2 3 4 7
4 2 5 6 7
5 4 5 7 8
6 2 4 5 7
$EndElements
)";

double volume(const Positions& x, const Vec4i& t) {
  return (x[t[1]] - x[t[0]]).cross(x[t[2]] - x[t[0]]).dot(x[t[3]] - x[t[0]]) / 6.0;
}

void expect_box(const io::TetMesh& m) {
  ASSERT_EQ(m.v.size(), 8u);
  ASSERT_EQ(m.t.size(), 5u);
  double total = 0;
  for (const auto& t : m.t) {
    const double v = volume(m.v, t);
    EXPECT_GT(v, 0.0) << "every tet positively oriented";
    total += v;
  }
  EXPECT_NEAR(total, 24.0, 1e-12);
}

TEST(TetMesh, TetgenNodeEleGiveTheBoxVolume) {
  const fs::path d = test::scratch_dir("tet_tetgen");
  test::write_text(d, "box.node", kNode);
  test::write_text(d, "box.ele", kEle);
  expect_box(io::read_tetgen(d / "box.ele"));
  expect_box(io::read_tetgen(d / "box.node"));
}

TEST(TetMesh, GmshV2AndV4GiveTheSameBox) {
  const fs::path d = test::scratch_dir("tet_gmsh");
  const auto a = io::read_gmsh(test::write_text(d, "a.msh", kMsh2)),
             b = io::read_gmsh(test::write_text(d, "b.msh", kMsh4));
  expect_box(a);
  expect_box(b);
  EXPECT_EQ(a.v, b.v);
  EXPECT_EQ(a.t, b.t);
}

TEST(TetMesh, MalformedFilesNameTheLine) {
  const fs::path d = test::scratch_dir("tet_bad");
  test::write_text(d, "flat.node", "4 3 0 0\n0 0 0 0\n1 1 0 0\n2 0 1 0\n3 1 1 0\n");
  test::write_text(d, "flat.ele", "1 4 0\n0 0 1 2 3\n");
  EXPECT_NE(test::error_of([&] { io::read_tetgen(d / "flat.ele"); }).find("flat.ele:2: tetrahedron 1 has zero volume"),
            std::string::npos);
  test::write_text(d, "far.node", kNode);
  test::write_text(d, "far.ele", "1 4 0\n1 1 2 4 9\n");
  EXPECT_NE(test::error_of([&] {
              io::read_tetgen(d / "far.ele");
            }).find("far.ele:2: node 9 out of range (far.node has 1..8)"),
            std::string::npos);
  test::write_text(d, "lonely.node", kNode);
  EXPECT_NE(test::error_of([&] { io::read_tetgen(d / "lonely.node"); }).find("lonely.ele' does not exist"),
            std::string::npos);
  test::write_text(d, "bin.msh", "$MeshFormat\n4.1 1 8\n");
  EXPECT_NE(test::error_of([&] { io::read_gmsh(d / "bin.msh"); }).find("bin.msh:2: binary .msh is not supported"),
            std::string::npos);
  test::write_text(
      d, "undef.msh",
      "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n1\n1 0 0 0\n$EndNodes\n$Elements\n1\n1 4 0 1 2 3 4\n");
  EXPECT_NE(test::error_of([&] { io::read_gmsh(d / "undef.msh"); }).find("undef.msh:10: element uses node 2"),
            std::string::npos);
  test::write_text(d, "none.msh", "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n1\n1 0 0 0\n$EndNodes\n");
  EXPECT_NE(test::error_of([&] { io::read_gmsh(d / "none.msh"); }).find("no tetrahedra"), std::string::npos);
}

std::string scene(const std::string& kind, const std::string& shape) {
  return "scene: t\ntime: {frames: 1}\nobjects:\n  - name: solid\n    kind: " + kind + "\n    shape: " + shape + "\n";
}

double scene_volume(const io::LoadedScene& s) {
  double total = 0;
  for (const auto& t : s.scene.topo.tets) total += volume(s.scene.state.x, t);
  return total;
}

TEST(TetMesh, ScenesLoadTetFilesAndRefuseOtherFormats) {
  const fs::path d = test::scratch_dir("tet_scene");
  test::write_text(d, "box.node", kNode);
  test::write_text(d, "box.ele", kEle);
  test::write_text(d, "box.msh", kMsh4);
  EXPECT_NEAR(scene_volume(io::load_scene_text(scene("tet_solid", "{type: mesh, path: box.ele}"), "s.yaml", d)), 24,
              1e-12);
  EXPECT_NEAR(scene_volume(io::load_scene_text(scene("tet_solid", "{type: mesh, path: box.msh}"), "s.yaml", d)), 24,
              1e-12);
  auto err = [&](const std::string& yaml) {
    try {
      io::load_scene_text(yaml, "s.yaml", d);
    } catch (const ConfigError& e) {
      return std::string(e.what());
    }
    return std::string("(no error)");
  };
  const std::string gltf = err(scene("shell", "{type: mesh, path: body.gltf}"));
  EXPECT_NE(gltf.find("s.yaml:6: 'objects[0].shape.path': unsupported mesh format '.gltf' (supported: .obj, .off, "
                      ".node, .ele, .msh)"),
            std::string::npos)
      << gltf;
  EXPECT_NE(err(scene("cloth", "{type: mesh, path: box.msh}")).find("a tet mesh (.msh) makes a tet_solid object"),
            std::string::npos);
}

TEST(TetMesh, TetgenFillsClosedObjSurfacesWithTheirVolume) {
  if (!find_program("tetgen")) GTEST_SKIP() << "tetgen is not installed (scripts/install-deps)";
  const fs::path d = test::scratch_dir("tet_tetgen_obj");
  double ball_volume = 0;
  {
    std::ofstream o(d / "box.obj");
    const auto m = gen::box(Vec3(1, 2, 3));
    for (const auto& p : m.v) o << "v " << p.x() << " " << p.y() << " " << p.z() << "\n";
    for (const auto& f : m.f) o << "f " << f[0] + 1 << " " << f[1] + 1 << " " << f[2] + 1 << "\n";
    std::ofstream s(d / "ball.obj");
    s.precision(17);
    const auto b = gen::sphere(0.5, 2);
    for (const auto& p : b.v) s << "v " << p.x() << " " << p.y() << " " << p.z() << "\n";
    for (const auto& f : b.f) s << "f " << f[0] + 1 << " " << f[1] + 1 << " " << f[2] + 1 << "\n";
    // The ball's enclosed volume by the divergence theorem, independent of any tet.
    for (const auto& f : b.f) ball_volume += b.v[f[0]].dot(b.v[f[1]].cross(b.v[f[2]])) / 6.0;
    ball_volume = std::abs(ball_volume);
  }
  const auto box =
      io::load_scene_text(scene("tet_solid", "{type: mesh, path: box.obj, max_volume: 0.05}"), "s.yaml", d);
  EXPECT_NEAR(scene_volume(box), 6.0, 1e-9);
  EXPECT_GE(box.scene.topo.tets.size(), 120u);
  for (const auto& t : box.scene.topo.tets) {
    EXPECT_GT(volume(box.scene.state.x, t), 0.0);
    EXPECT_LE(volume(box.scene.state.x, t), 0.05 * (1 + 1e-9));
  }
  const auto ball = io::load_scene_text(scene("tet_solid", "{type: mesh, path: ball.obj}"), "s.yaml", d);
  EXPECT_NEAR(scene_volume(ball), ball_volume, 1e-9 * ball_volume);
  // An open surface is refused before tetgen runs.
  {
    std::ofstream o(d / "open.obj");
    o << "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 2 3 4\n";
  }
  try {
    io::load_scene_text(scene("tet_solid", "{type: mesh, path: open.obj}"), "s.yaml", d);
    ADD_FAILURE() << "an open surface was accepted";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("borders only one face"), std::string::npos) << e.what();
  }
}

/// A bumpy closed surface (an icosphere of 642 vertices, each pushed radially by a fixed factor in
/// [0.55, 1.45]) is not Delaunay-conforming: tetgen -p split its edges and faces to recover them and
/// -q then refined around the splits, edges down to 1/10 of the surface's shortest (the mechanism
/// of CGAL's triceratops: 7e-7 against 0.02). The default fill keeps the surface: every surface
/// vertex and face is the fill's boundary, and no fill edge is shorter than half the surface's.
TEST(TetMesh, DefaultFillKeepsTheSurfaceAndItsShortestEdge) {
  if (!find_program("tetgen")) GTEST_SKIP() << "tetgen is not installed (scripts/install-deps)";
  const fs::path d = test::scratch_dir("tet_tetgen_bumpy");
  auto b = gen::sphere(0.5, 3);
  uint32_t seed = 12345;  // a fixed linear congruential sequence: the same surface everywhere
  for (auto& p : b.v) {
    seed = seed * 1664525u + 1013904223u;
    p *= 0.55 + 0.9 * double(seed >> 8) / double(1u << 24);
  }
  double surface_edge = 1e300;
  {
    std::ofstream o(d / "bumpy.obj");
    o.precision(17);
    for (const auto& p : b.v) o << "v " << p.x() << " " << p.y() << " " << p.z() << "\n";
    for (const auto& f : b.f) {
      o << "f " << f[0] + 1 << " " << f[1] + 1 << " " << f[2] + 1 << "\n";
      for (int k = 0; k < 3; ++k) surface_edge = std::min(surface_edge, (b.v[f[k]] - b.v[f[(k + 1) % 3]]).norm());
    }
  }
  const auto s = io::load_scene_text(scene("tet_solid", "{type: mesh, path: bumpy.obj}"), "s.yaml", d);
  const auto& x = s.scene.state.x;
  double fill_edge = 1e300;
  size_t boundary_faces = 0;
  std::map<std::array<Index, 3>, int> faces;  // sorted triangle -> tets holding it
  for (const auto& t : s.scene.topo.tets) {
    EXPECT_GT(volume(x, t), 0.0);
    for (int a = 0; a < 4; ++a)
      for (int c = a + 1; c < 4; ++c) fill_edge = std::min(fill_edge, (x[t[a]] - x[t[c]]).norm());
    for (int skip = 0; skip < 4; ++skip) {
      std::array<Index, 3> tri;
      for (int k = 0, n = 0; k < 4; ++k)
        if (k != skip) tri[n++] = t[k];
      std::sort(tri.begin(), tri.end());
      ++faces[tri];
    }
  }
  for (const auto& [tri, n] : faces) boundary_faces += n == 1;
  EXPECT_EQ(boundary_faces, b.f.size());
  EXPECT_GE(fill_edge, 0.5 * surface_edge) << "the fill split the surface";
  EXPECT_LT(size_t(s.scene.topo.num_vertices()), 4 * b.v.size());
}

}  // namespace

/// tetgen aborts on a self-intersecting surface without saying why (CGAL's cow, bull, elk and
/// camel: "terminate called after throwing an instance of 'int'"): the error counts the
/// intersecting face pairs and names one pair by the lines of the file, here one face of each of
/// two closed boxes that overlap.
TEST(TetMesh, ASelfIntersectingSurfaceIsRefusedNamingTwoFacesByLine) {
  if (!find_program("tetgen")) GTEST_SKIP() << "tetgen is not installed (scripts/install-deps)";
  const fs::path d = test::scratch_dir("tet_tetgen_crossing");
  const auto box = gen::box(Vec3(1, 1, 1));
  std::ofstream o(d / "two.obj");
  int line = 0, first_a = 0, last_a = 0, first_b = 0, last_b = 0;
  for (const double shift : {0.0, 0.5}) {
    const Index base = shift == 0.0 ? 0 : static_cast<Index>(box.v.size());
    for (const auto& p : box.v) o << "v " << p.x() + shift << " " << p.y() + shift << " " << p.z() << "\n", ++line;
    (shift == 0.0 ? first_a : first_b) = line + 1;
    for (const auto& f : box.f)
      o << "f " << base + f[0] + 1 << " " << base + f[1] + 1 << " " << base + f[2] + 1 << "\n", ++line;
    (shift == 0.0 ? last_a : last_b) = line;
  }
  o.close();
  try {
    io::load_scene_text(scene("tet_solid", "{type: mesh, path: two.obj}"), "s.yaml", d);
    ADD_FAILURE() << "two overlapping boxes were filled";
  } catch (const ConfigError& e) {
    EXPECT_EQ(e.key_path(), "objects[0].shape.path");
    const std::string w = e.what();
    std::smatch m;
    ASSERT_TRUE(std::regex_search(
        w, m,
        std::regex(
            R"(intersects itself \((\d+) pairs? of faces, e\.g\. the face of line (\d+) and the face of line (\d+)\))")))
        << w;
    EXPECT_GT(std::stoi(m[1]), 0);
    const int a = std::stoi(m[2]), b = std::stoi(m[3]);
    EXPECT_TRUE((a >= first_a && a <= last_a && b >= first_b && b <= last_b) ||
                (b >= first_a && b <= last_a && a >= first_b && a <= last_b))
        << w;
  }
}
