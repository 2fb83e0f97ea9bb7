// The OBJ frame reader and topology_from_frame never drop geometry silently: every element is
// either turned into an audited primitive or refused naming the file and line.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <functional>
#include <string>

#include "ccfr/core/error.hpp"
#include "ccfr/core/topology.hpp"
#include "ccfr/io/frame_topology.hpp"
#include "ccfr/io/obj.hpp"
#include "ccfr/io/scene_loader.hpp"
#include "cli_support.hpp"

namespace fs = std::filesystem;
using namespace ccfr;

namespace {
fs::path write_obj(const std::string& name, const std::string& text) {
  const fs::path p = fs::temp_directory_path() / ("ccfr_reader_" + name + ".obj");
  std::ofstream(p) << text;
  return p;
}

}  // namespace

TEST(FrameReader, StatementsCarryingGeometryItCannotReadAreRefused) {
  for (const char* tag : {"curv 0 1 1 2", "surf 0 1 0 1 1 2 3 4", "call other.obj", "cstype bspline", "pt 1"}) {
    const fs::path p = write_obj("freeform", std::string("o a\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n") + tag + "\n");
    const std::string e = test::error_of([&] { io::read_frame_obj(p); });
    EXPECT_NE(e.find("ccfr_reader_freeform.obj:6: unsupported OBJ statement"), std::string::npos) << tag << ": " << e;
  }
  const fs::path empty_p = write_obj("emptyp", "o a\nv 0 0 0\np\n");
  EXPECT_NE(test::error_of([&] { io::read_frame_obj(empty_p); }).find("ccfr_reader_emptyp.obj:3:"), std::string::npos);
  // Display and texture statements are ignored, polygons fan-triangulated, negative indices relative.
  const auto fr = io::read_frame_obj(write_obj(
      "display", "mtllib m.mtl\no a\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvn 0 0 1\n  # note\ng side\n"));
  EXPECT_EQ(fr.v.size(), 4u);
  const auto quad = io::read_frame_obj(
      write_obj("quad", "o a\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nusemtl x\ns 1\nf -4 -3/1 -2//1 -1\n"));
  EXPECT_EQ(quad.faces, (std::vector<Vec3i>{{0, 1, 2}, {0, 2, 3}}));
}

TEST(FrameReader, MixedBlocksAndElementlessVerticesAreRefusedWithFileAndLine) {
  const fs::path points = write_obj("mixp", "o a\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 0.2 0.2 0\np 4\nf 1 2 3\n");
  const io::Frame fp = io::read_frame_obj(points);
  EXPECT_EQ(fp.objects.at(0).line, 1);
  EXPECT_EQ(fp.objects.at(0).first_point_line, 6);
  EXPECT_EQ(fp.objects.at(0).first_face_line, 7);
  EXPECT_NE(test::error_of([&] {
              io::topology_from_frame(fp, points);
            }).find("ccfr_reader_mixp.obj:7: object 'a' mixes faces (f) and points (p)"),
            std::string::npos);
  const fs::path lines = write_obj("mixl", "o h\nv 0 0 0\nv 1 0 0\nv 2 0 0\nl 1 2 3\np 1\n");
  EXPECT_NE(test::error_of([&] {
              io::topology_from_frame(io::read_frame_obj(lines), lines);
            }).find("ccfr_reader_mixl.obj:6: object 'h' mixes lines (l) and points (p)"),
            std::string::npos);
  const fs::path bare = write_obj("bare", "o a\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\no cloud\nv 5 5 5\nv 6 6 6\n");
  EXPECT_NE(test::error_of([&] {
              io::topology_from_frame(io::read_frame_obj(bare), bare);
            }).find("ccfr_reader_bare.obj:6: object 'cloud' has 2 vertices but no f, l or p element"),
            std::string::npos);
  // One kind per block: kinds follow, and vertices used by no element (tet interiors) are counted.
  const fs::path ok = write_obj(
      "ok",
      "o s\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 0.3 0.3 0.3\nf 1 2 3\no h\nv 0 0 1\nv 1 0 1\nl 5 6\no d\nv 3 3 3\np 7\n");
  const Topology t = io::topology_from_frame(io::read_frame_obj(ok), ok);
  ASSERT_EQ(t.objects.size(), 3u);
  EXPECT_EQ(t.objects[0].kind, ObjectKind::shell);
  EXPECT_EQ(t.objects[1].kind, ObjectKind::strand);
  EXPECT_EQ(t.objects[2].kind, ObjectKind::particles);
  EXPECT_EQ(io::unreferenced_vertices(t), 1);
}

// Coordinates beyond ccfr's bound (|x| <= 1e6) or beyond double range are refused where they are
// read, naming the file, line and vertex: an OBJ obstacle at 1e200 used to pass the loader (or be
// called "zero area"), run, and abort the renderer in Embree.
TEST(FrameReader, CoordinatesBeyondTheBoundAreRefusedWithFileLineAndVertex) {
  for (const char* bad : {"1e200", "-1e200", "1000000.5", "1e39", "1e309"}) {
    const fs::path p = write_obj("huge", std::string("o a\nv 0 0 0\nv 1 0 0\nv 0 ") + bad + " 0\nf 1 2 3\n");
    const std::string e = test::error_of([&] { io::read_frame_obj(p); });
    EXPECT_NE(e.find("ccfr_reader_huge.obj:4: vertex 3: "), std::string::npos) << bad << ": " << e;
    EXPECT_NE(e.find(std::string(bad) == "1e309" ? "non-finite" : "beyond +-1e6"), std::string::npos) << e;
  }
  // The bound itself is accepted.
  EXPECT_EQ(io::read_frame_obj(write_obj("bound", "o a\nv 0 0 0\nv 1e6 0 0\nv 0 -1e6 0\nf 1 2 3\n")).v[1].x(), 1e6);

  const fs::path d = test::scratch_dir("reader_bounds");
  test::write_text(d, "far.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1e200 0\n3 0 1 2\n");
  const std::string off = test::error_of([&] { io::read_off_mesh(d / "far.off"); });
  EXPECT_NE(off.find("far.off:5: coordinate '1e200' is beyond +-1e6"), std::string::npos) << off;

  // In a scene: the OBJ obstacle's own line, not "zero area".
  test::write_text(d, "far.obj", "v 0 0 0\nv 1 0 0\nv 0 1e200 0\nf 1 2 3\n");
  auto scene = [](const std::string& path, double scale) {
    return "scene: t\ntime: {frames: 1}\nobjects:\n  - name: wall\n    kind: obstacle\n    shape: {type: mesh, path: " +
           path + "}\n    transform: {scale: " + std::to_string(scale) + "}\n";
  };
  std::string e = test::error_of([&] { io::load_scene_text(scene("far.obj", 1.0), "s.yaml", d); });
  EXPECT_NE(e.find("far.obj:3: vertex 3: coordinate '1e200' is beyond +-1e6"), std::string::npos) << e;
  EXPECT_EQ(e.find("zero area"), std::string::npos) << e;
  // Within the bound in the file, beyond it once placed: the vertex and the transform are named.
  test::write_text(d, "km.obj", "v 0 0 0\nv 1000 0 0\nv 0 1000 0\nf 1 2 3\n");
  e = test::error_of([&] { io::load_scene_text(scene("km.obj", 5000.0), "s.yaml", d); });
  EXPECT_NE(e.find("objects[0].transform"), std::string::npos) << e;
  EXPECT_NE(e.find("object 'wall': vertex 2 lies at (5e+06, 0, 0) once placed, beyond +-1e6 m"), std::string::npos)
      << e;
  EXPECT_NO_THROW(io::load_scene_text(scene("km.obj", 1000.0), "s.yaml", d));
}

// What used to be read silently wrong: a lone CR hid every statement after it on its line, text
// after a vertex's coordinates was ignored, a strand could fold onto itself; a UTF-8 BOM was an
// invisible unsupported statement (YAML accepts one).
TEST(FrameReader, LoneCarriageReturnsTrailingTextAndRevisitingLinesAreRefused) {
  const fs::path cr = write_obj("lone_cr", "o a\rv 0 0 0\rv 1 0 0\rv 0 1 0\rf 1 2 3\r");
  EXPECT_NE(test::error_of([&] { io::read_frame_obj(cr); }).find("ccfr_reader_lone_cr.obj:1: carriage return"),
            std::string::npos);
  const fs::path junk = write_obj("junk", "o a\nv 0 0 0 junk\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
  EXPECT_NE(test::error_of([&] { io::read_frame_obj(junk); }).find("ccfr_reader_junk.obj:2: unexpected 'junk'"),
            std::string::npos);
  const fs::path fold = write_obj("fold", "o s\nv 0 0 0\nv 1 0 0\nl 1 2 1 2\n");
  EXPECT_NE(
      test::error_of([&] { io::read_frame_obj(fold); }).find("ccfr_reader_fold.obj:4: line visits vertex 1 twice"),
      std::string::npos);
  // Still read: CRLF, a weight or a colour after x y z, a closed loop, a BOM.
  const auto ok = io::read_frame_obj(
      write_obj("fine", "\xEF\xBB\xBFo a\r\nv 0 0 0 1\r\nv 1 0 0 0.5 0.5 0.5\r\nv 0 1 0 1 0 0 1\r\nl 1 2 3 1\r\n"));
  EXPECT_EQ(ok.v.size(), 3u);
  ASSERT_EQ(ok.objects.size(), 1u);
  EXPECT_EQ(ok.objects[0].name, "a");
  EXPECT_EQ(ok.lines.size(), 1u);
}

// A run's OBJ frame carries its scene fingerprint in its first line; other frames carry none.
TEST(FrameReader, SceneFingerprintRoundTrips) {
  TopologyBuilder b;
  b.add_object("quad", ObjectKind::cloth, 3, {{0, 1, 2}});
  const Topology t = b.finish();
  const Positions x{Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0)};
  const fs::path p = fs::temp_directory_path() / "ccfr_reader_fingerprint.obj";
  io::write_frame_obj(p, t, x, 0x0123456789abcdefull);
  EXPECT_EQ(io::read_frame_obj(p).scene_fingerprint, 0x0123456789abcdefull);
  io::write_frame_obj(p, t, x);
  EXPECT_EQ(io::read_frame_obj(p).scene_fingerprint, 0u);
}

// A non-convex polygon was fan-triangulated into a folded triangle; a convex one still reads.
TEST(FrameReader, NonConvexPolygonsAreRefused) {
  // An arrowhead: corner 3 at (1, 0.5) points inwards, so the fan (1 2 3), (1 3 4) overlaps.
  const fs::path p = write_obj("nonconvex", "o a\nv 0 0 0\nv 2 0 0\nv 0.5 0.5 0\nv 0 2 0\nf 1 2 3 4\n");
  EXPECT_NE(test::error_of([&] { io::read_frame_obj(p); }).find("ccfr_reader_nonconvex.obj:6: non-convex polygon"),
            std::string::npos);
  const auto pent =
      io::read_frame_obj(write_obj("pentagon", "o a\nv 0 0 0\nv 2 0 0\nv 3 1 0\nv 1 2 0\nv -1 1 0\nf 1 2 3 4 5\n"));
  EXPECT_EQ(pent.faces.size(), 3u);
}
