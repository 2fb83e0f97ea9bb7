// The OBJ frame reader and topology_from_frame never drop geometry silently: every element is
// either turned into an audited primitive or refused naming the file and line.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <functional>
#include <string>

#include "ccfr/core/error.hpp"
#include "ccfr/io/frame_topology.hpp"
#include "ccfr/io/obj.hpp"
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
