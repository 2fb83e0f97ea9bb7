// Geomview OFF surfaces (the format of CGAL's data meshes and most scanned-mesh collections):
// polygons fan-triangulated to the same triangles as the OBJ reader gives, header variants, and one
// error naming the file and line for every malformed input. Volumes against the divergence theorem.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>

#include "ccfr/core/error.hpp"
#include "ccfr/core/process.hpp"
#include "ccfr/io/obj.hpp"
#include "ccfr/io/scene_loader.hpp"
#include "cli_support.hpp"

using namespace ccfr;
namespace fs = std::filesystem;

namespace {

// The cube [-1, 1]^3 as six outward quads, 0-based (Geomview's own example layout).
const char* kCubeOff = R"(OFF
# a comment line, then the counts
8 6 0
-1 -1 -1
 1 -1 -1
 1  1 -1
-1  1 -1
-1 -1  1
 1 -1  1
 1  1  1
-1  1  1

4 0 3 2 1
4 4 5 6 7
4 0 1 5 4
4 1 2 6 5
4 2 3 7 6
4 3 0 4 7
)";

/// Signed enclosed volume by the divergence theorem (positive for outward winding).
double enclosed_volume(const io::ObjMesh& m) {
  double v = 0;
  for (const auto& f : m.f) v += m.v[f[0]].dot(m.v[f[1]].cross(m.v[f[2]])) / 6.0;
  return v;
}

/// Every undirected edge used by exactly two faces, once in each direction: a closed, consistently
/// wound surface.
bool closed_and_oriented(const io::ObjMesh& m) {
  std::map<std::pair<Index, Index>, int> directed;
  for (const auto& f : m.f)
    for (int k = 0; k < 3; ++k) ++directed[{f[k], f[(k + 1) % 3]}];
  for (const auto& [e, n] : directed) {
    if (n != 1) return false;
    const auto back = directed.find({e.second, e.first});
    if (back == directed.end() || back->second != 1) return false;
  }
  return true;
}

}  // namespace

TEST(Off, CubeQuadsGiveTheSameTrianglesAsObjAndItsVolume) {
  const fs::path d = test::scratch_dir("off_cube");
  const auto m = io::read_off_mesh(test::write_text(d, "cube.off", kCubeOff));
  ASSERT_EQ(m.v.size(), 8u);
  ASSERT_EQ(m.f.size(), 12u);
  EXPECT_NEAR(enclosed_volume(m), 8.0, 1e-12);
  EXPECT_TRUE(closed_and_oriented(m));
  // The same cube as OBJ (1-based): the readers agree triangle for triangle.
  std::string obj;
  for (const auto& p : m.v)
    obj += "v " + std::to_string(p.x()) + " " + std::to_string(p.y()) + " " + std::to_string(p.z()) + "\n";
  for (const char* q : {"1 4 3 2", "5 6 7 8", "1 2 6 5", "2 3 7 6", "3 4 8 7", "4 1 5 8"})
    obj += std::string("f ") + q + "\n";
  const auto o = io::read_obj_mesh(test::write_text(d, "cube.obj", obj));
  ASSERT_EQ(o.f.size(), m.f.size());
  for (size_t i = 0; i < m.f.size(); ++i) EXPECT_EQ(o.f[i], m.f[i]) << "triangle " << i;
  // Each triangle names the line of its face: the first quad is on line 13 (after a blank line).
  EXPECT_EQ(m.face_lines.front(), 13);
  EXPECT_EQ(m.face_lines.back(), 18);
}

TEST(Off, HeaderVariantsColoursNormalsAndCountsOnTheHeaderLine) {
  const fs::path d = test::scratch_dir("off_variants");
  // Counts on the header's line, a triangle with a face colour, comments after data.
  const auto a =
      io::read_off_mesh(test::write_text(d, "a.off", "OFF 3 1 0\n0 0 0 # origin\n1 0 0\n0 1 0\n3 0 1 2 255 0 0\n"));
  ASSERT_EQ(a.f.size(), 1u);
  EXPECT_EQ(a.f[0], Vec3i(0, 1, 2));
  EXPECT_EQ(a.v[1], Vec3(1, 0, 0));
  // COFF and NOFF carry colours and normals after the coordinates: ignored.
  const auto c = io::read_off_mesh(
      test::write_text(d, "c.off", "COFF\n3 1 3\n0 0 0 1 0 0 1\n2 0 0 1 0 0 1\n0 3 0 1 0 0 1\n3 0 1 2\n"));
  EXPECT_EQ(c.v[2], Vec3(0, 3, 0));
  const auto n =
      io::read_off_mesh(test::write_text(d, "n.off", "NOFF\n3 1 0\n0 0 1 0 0 1\n1 0 1 0 0 1\n0 1 1 0 0 1\n3 0 1 2\n"));
  EXPECT_EQ(n.v[0], Vec3(0, 0, 1));
  // No header keyword at all (some writers omit it): the first line is the counts.
  const auto h = io::read_off_mesh(test::write_text(d, "h.off", "3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 2 1 0\n"));
  EXPECT_EQ(h.f[0], Vec3i(2, 1, 0));
  // A pentagon becomes a fan of three triangles from its first vertex.
  const auto p = io::read_off_mesh(test::write_text(
      d, "p.off", "OFF\n5 1 0\n1 0 0\n0.309 0.951 0\n-0.809 0.588 0\n-0.809 -0.588 0\n0.309 -0.951 0\n5 0 1 2 3 4\n"));
  ASSERT_EQ(p.f.size(), 3u);
  EXPECT_EQ(p.f[1], Vec3i(0, 2, 3));
}

TEST(Off, MalformedFilesNameTheFileAndLine) {
  const fs::path d = test::scratch_dir("off_bad");
  auto err = [&](const std::string& name, const std::string& text) {
    return test::error_of([&] { io::read_off_mesh(test::write_text(d, name, text)); });
  };
  auto has = [](const std::string& e, const std::string& what) { return e.find(what) != std::string::npos; };
  std::string e = err("empty.off", "# nothing\n\n");
  EXPECT_TRUE(has(e, "empty.off: empty OFF file")) << e;
  e = err("nocounts.off", "OFF\n");
  EXPECT_TRUE(has(e, "nocounts.off:1: missing the vertex and face counts")) << e;
  e = err("negative.off", "OFF\n-3 1 0\n");
  EXPECT_TRUE(has(e, "negative.off:2: bad vertex count '-3'")) << e;
  // A count the file cannot hold is refused before anything is reserved (no bad_alloc).
  e = err("huge.off", "OFF\n2000000000 3 0\n0 0 0\n");
  EXPECT_TRUE(has(e, "huge.off:2: counts 2000000000 vertices, 3 faces exceed what a")) << e;
  e = err("short.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n");
  EXPECT_TRUE(has(e, "short.off:4: ends after 2 of 3 vertices")) << e;
  e = err("nofaces.off", "OFF\n3 2 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n");
  EXPECT_TRUE(has(e, "nofaces.off:6: ends after 1 of 2 faces")) << e;
  e = err("range.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n");
  EXPECT_TRUE(has(e, "range.off:6: vertex index 3 out of range (0-based, 3 vertices)")) << e;
  e = err("negidx.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 -1 2\n");
  EXPECT_TRUE(has(e, "negidx.off:6: vertex index -1 out of range")) << e;
  e = err("two.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n2 0 1\n");
  EXPECT_TRUE(has(e, "two.off:6: face needs at least 3 vertices")) << e;
  e = err("missing.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n4 0 1 2\n");
  EXPECT_TRUE(has(e, "missing.off:6: face declares 4 vertices but lists 3")) << e;
  e = err("nan.off", "OFF\n3 1 0\n0 nan 0\n1 0 0\n0 1 0\n3 0 1 2\n");
  EXPECT_TRUE(has(e, "nan.off:3: non-finite coordinate 'nan'")) << e;
  e = err("coord.off", "OFF\n3 1 0\n0 0x 0\n1 0 0\n0 1 0\n3 0 1 2\n");
  EXPECT_TRUE(has(e, "coord.off:3: bad coordinate '0x'")) << e;
  e = err("twod.off", "OFF\n3 1 0\n0 0\n1 0 0\n0 1 0\n3 0 1 2\n");
  EXPECT_TRUE(has(e, "twod.off:3: vertex needs 3 coordinates")) << e;
  e = err("four.off", "4OFF\n3 1 0\n0 0 0 1\n1 0 0 1\n0 1 0 1\n3 0 1 2\n");
  EXPECT_TRUE(has(e, "four.off:1: '4OFF': only 3-D vertices are supported")) << e;
  e = err("bin.off", "OFF BINARY\n");
  EXPECT_TRUE(has(e, "bin.off:1: binary OFF is not supported")) << e;
  e = err("xoff.off", "XOFF\n3 1 0\n");
  EXPECT_TRUE(has(e, "xoff.off:1: unknown OFF header 'XOFF'")) << e;
  e = err("trail.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n3 0 2 1\n");
  EXPECT_TRUE(has(e, "trail.off:7: unexpected data after the 1 faces declared")) << e;
  e = err("novert.off", "OFF\n0 0 0\n");
  EXPECT_TRUE(has(e, "novert.off:2: no vertices")) << e;
  EXPECT_TRUE(has(test::error_of([&] { io::read_off_mesh(d / "absent.off"); }), "absent.off' does not exist"));
  EXPECT_TRUE(has(test::error_of([&] { io::read_off_mesh(d); }), "is not a regular file"));
}

TEST(Off, ScenesLoadOffSurfacesAsRigidBodiesAndTetSolids) {
  const fs::path d = test::scratch_dir("off_scene");
  test::write_text(d, "cube.off", kCubeOff);
  auto scene = [](const std::string& kind, const std::string& shape) {
    return "scene: t\ntime: {frames: 1}\nobjects:\n  - name: body\n    kind: " + kind + "\n    shape: " + shape +
           "\n    transform: {scale: 0.05}\n";
  };
  const auto rigid = io::load_scene_text(scene("rigid", "{type: mesh, path: cube.off}"), "s.yaml", d);
  EXPECT_EQ(rigid.scene.topo.num_vertices(), 8);
  EXPECT_EQ(rigid.scene.topo.faces.size(), 12u);
  // A broken OFF file is a config error naming the key and the file's own line.
  test::write_text(d, "bad.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n");
  try {
    io::load_scene_text(scene("obstacle", "{type: mesh, path: bad.off}"), "s.yaml", d);
    ADD_FAILURE() << "expected a ConfigError";
  } catch (const ConfigError& e) {
    EXPECT_EQ(e.key_path(), "objects[0].shape.path");
    EXPECT_NE(std::string(e.what()).find("bad.off:6: vertex index 7 out of range"), std::string::npos) << e.what();
  }
  if (!find_program("tetgen")) GTEST_SKIP() << "tetgen is not installed (scripts/install-deps)";
  // max_volume is in m³ of the placed (scaled) solid: the 0.1 m cube of 1e-3 m³ with tets of at most
  // 1e-5 m³ (in the file's units that bound would be 8e-5 of the cube's 8: millions of tets).
  const auto solid =
      io::load_scene_text(scene("tet_solid", "{type: mesh, path: cube.off, max_volume: 1.0e-5}"), "s.yaml", d);
  double volume = 0;
  const auto& x = solid.scene.state.x;
  for (const auto& t : solid.scene.topo.tets) {
    const double vt = (x[t[1]] - x[t[0]]).cross(x[t[2]] - x[t[0]]).dot(x[t[3]] - x[t[0]]) / 6.0;
    EXPECT_LE(vt, 1.0e-5 * (1 + 1e-9));
    volume += vt;
  }
  EXPECT_NEAR(volume, 1.0e-3, 1e-15);
  EXPECT_GE(solid.scene.topo.tets.size(), 100u);
  EXPECT_LE(solid.scene.topo.tets.size(), 2000u);
}

/// The scanned meshes of configs/scanned (scripts/fetch-scanned-meshes, run by scripts/install-deps)
/// read as the closed, consistently wound surfaces their counts promise.
TEST(Off, CgalScannedMeshesAreClosedAndOriented) {
  const fs::path dir = fs::path(CCFR_SOURCE_DIR) / "configs" / "scanned" / "meshes";
  if (!fs::exists(dir / "bunny00.off")) GTEST_SKIP() << dir << " not fetched (scripts/fetch-scanned-meshes)";
  const std::map<std::string, std::pair<size_t, size_t>> counts = {{"bunny00.off", {37706, 75408}},
                                                                   {"armadillo.off", {26002, 52000}},
                                                                   {"knot1.off", {3200, 6400}},
                                                                   {"elephant.off", {2775, 5558}}};
  for (const auto& [name, c] : counts) {
    SCOPED_TRACE(name);
    const auto m = io::read_off_mesh(dir / name);
    EXPECT_EQ(m.v.size(), c.first);
    EXPECT_EQ(m.f.size(), c.second);
    EXPECT_TRUE(closed_and_oriented(m));
    EXPECT_GT(std::abs(enclosed_volume(m)), 0.0);
  }
}
