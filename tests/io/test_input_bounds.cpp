// Hostile input the loaders must bound or refuse with one clear error (issue 37): YAML alias
// bombs and deep nesting, files that are not regular files (FIFO, /dev/zero, symlink loops,
// names too long), shapes without their required size, header counts a file cannot hold, a
// Gmsh section without its end marker, rotations without an axis or beyond what slerp can
// interpolate, names that are not UTF-8, physical values beyond their bounds, mesh elements an
// object would drop, motions that end before they start, and a --set holding two documents.
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "ccfr/core/error.hpp"
#include "ccfr/io/obj.hpp"
#include "ccfr/io/scene_loader.hpp"
#include "ccfr/io/tet_mesh.hpp"
#include "ccfr/io/user_file.hpp"
#include "config_support.hpp"

using namespace ccfr;
using ccfr::test::config_error;
namespace fs = std::filesystem;

namespace {

const char* kSheet = R"(time: {frames: 1}
objects:
  - name: sheet
    kind: cloth
    shape: {type: grid, size: [1, 1], resolution: [2, 2]}
)";

fs::path dir(const std::string& name) {
  const fs::path d = fs::path(CCFR_BINARY_DIR) / "test-scratch" / ("input_bounds_" + name);
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}

fs::path write(const fs::path& p, const std::string& text) {
  std::ofstream(p, std::ios::binary) << text;
  return p;
}

/// The message of the ccfr::Error `f` throws ("(no error)" if none; other exceptions fail).
template <class F>
std::string error_of(F&& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  } catch (const std::exception& e) {
    ADD_FAILURE() << "not a ccfr::Error: " << e.what();
    return e.what();
  }
  return "(no error)";
}

bool has(const std::string& s, const std::string& part) { return s.find(part) != std::string::npos; }

/// An obstacle box with `extra` keys (YAML lines at the object's indentation).
std::string obstacle(const std::string& extra) {
  return std::string(kSheet) + "  - name: box\n    kind: obstacle\n    shape: {type: box, size: [1, 1, 1]}\n" + extra;
}

}  // namespace

// Nine levels of ten aliases each: 10^9 nodes from about 500 bytes. The scan counts each alias
// as the nodes it repeats and stops past 2^21, at the level that crosses it: l6 on line 7
// stands for 1 + 10 x 211111 = 2111111 nodes (brute force: l0 is 2, each level 1 + 10 x the last).
TEST(InputBounds, AliasBombIsRefusedWhileParsing) {
  std::string y = "l0: &l0 [x]\n";
  for (int i = 1; i < 10; ++i) {
    y += "l" + std::to_string(i) + ": &l" + std::to_string(i) + " [";
    for (int k = 0; k < 10; ++k) y += (k ? ", *l" : "*l") + std::to_string(i - 1);
    y += "]\n";
  }
  const ConfigError e = config_error(y + kSheet);
  EXPECT_TRUE(has(e.what(), "aliases")) << e.what();
  EXPECT_EQ(e.line(), 7) << e.what();
  // Aliases within the bound stay legal: a material reused by two objects.
  EXPECT_NO_THROW(io::load_scene_text(
      "time: {frames: 1}\nobjects:\n  - {name: a, kind: cloth, shape: &g {type: grid, size: [1, 1], resolution: "
      "[2, 2]}}\n  - {name: b, kind: cloth, shape: *g, transform: {translate: [0, 1, 0]}}\n",
      "scene.yaml", "."));
}

// yaml-cpp links an alias inside its own anchor into a cycle; every walk overflowed the stack.
TEST(InputBounds, RecursiveAliasesAreRefused) {
  for (const std::string& y : std::vector<std::string>{
           "x: &a [*a]\n", "objects: &a [{name: s, kind: cloth, pins: *a}]\n", "a: &m {b: {c: *m}}\n"}) {
    SCOPED_TRACE(y);
    const ConfigError e = config_error(y);
    EXPECT_TRUE(has(e.what(), "would contain itself")) << e.what();
    EXPECT_EQ(e.line(), 1);
  }
}

TEST(InputBounds, DeepNestingNamesTheDepthNotABadFile) {
  for (const int depth : {65, 3000}) {
    SCOPED_TRACE(depth);
    const ConfigError e = config_error("objects: " + std::string(depth, '[') + std::string(depth, ']') + "\n");
    EXPECT_TRUE(has(e.what(), "nesting too deep")) << e.what();
    EXPECT_TRUE(has(e.what(), "64")) << e.what();
    EXPECT_FALSE(has(e.what(), "bad file")) << e.what();
    EXPECT_EQ(e.line(), 1);
  }
  const ConfigError m = config_error("objects:\n" + [] {
    std::string s;
    for (int i = 0; i < 70; ++i) s += std::string(2 * i + 2, ' ') + "- \n";
    return s;
  }());
  EXPECT_TRUE(has(m.what(), "nesting too deep")) << m.what();
}

// A FIFO would block the read forever and /dev/zero never ends: both are refused from their
// stat before any open. A symlink loop and a name beyond NAME_MAX are errors naming the path.
TEST(InputBounds, SceneAndMeshFilesMustBeRegularFiles) {
  const fs::path d = dir("special");
  const fs::path fifo = d / "scene.yaml";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0644), 0);
  std::string m = error_of([&] { io::load_scene(fifo); });
  EXPECT_TRUE(has(m, "FIFO")) << m;
  EXPECT_TRUE(has(m, fifo.string())) << m;

  fs::create_symlink("/dev/zero", d / "zero.obj");
  m = error_of([&] { io::read_obj_mesh(d / "zero.obj"); });
  EXPECT_TRUE(has(m, "character device")) << m;
  m = error_of([&] { io::read_off_mesh(d / "zero.obj"); });
  EXPECT_TRUE(has(m, "character device")) << m;
  fs::create_symlink("/dev/zero", d / "zero.node");
  write(d / "zero.ele", "1 4 0\n1 1 2 3 4\n");
  m = error_of([&] { io::read_tetgen(d / "zero.node"); });
  EXPECT_TRUE(has(m, "character device")) << m;
  ::mkfifo((d / "pipe.msh").c_str(), 0644);
  m = error_of([&] { io::read_gmsh(d / "pipe.msh"); });
  EXPECT_TRUE(has(m, "FIFO")) << m;

  fs::create_symlink(d / "loop_b.yaml", d / "loop_a.yaml");
  fs::create_symlink(d / "loop_a.yaml", d / "loop_b.yaml");
  m = error_of([&] { io::load_scene(d / "loop_a.yaml"); });
  EXPECT_TRUE(has(m, "cannot access scene file")) << m;
  EXPECT_TRUE(has(m, "symbolic links")) << m;
  m = error_of([&] { io::load_scene(d / (std::string(300, 'a') + ".yaml")); });
  EXPECT_TRUE(has(m, "File name too long")) << m;

  // From a scene, the error names the shape.path key.
  fs::create_symlink(d / "mloop_b.obj", d / "mloop_a.obj");
  fs::create_symlink(d / "mloop_a.obj", d / "mloop_b.obj");
  for (const std::string file : {"mloop_a.obj", "zero.obj"}) {
    const ConfigError e =
        config_error("objects:\n  - name: m\n    kind: obstacle\n    shape: {type: mesh, path: " + file + "}\n", {}, d);
    EXPECT_EQ(e.key_path(), "objects[0].shape.path") << e.what();
    EXPECT_EQ(e.line(), 4) << e.what();
  }
}

TEST(InputBounds, UserFileSizeBound) {
  const fs::path d = dir("size");
  write(d / "big.obj", std::string(2000, '#'));
  const std::string m = error_of([&] { io::check_user_file(d / "big.obj", "mesh file", 1000); });
  EXPECT_TRUE(has(m, "2000 bytes")) << m;
  EXPECT_EQ(io::check_user_file(d / "big.obj", "mesh file", 2000), 2000u);
  EXPECT_EQ(io::read_user_file(d / "big.obj", "mesh file", 2000).size(), 2000u);
}

TEST(InputBounds, BoxesWithoutSizeAreMissingKeyErrors) {
  for (const std::string& s : std::vector<std::string>{
           "{name: b, kind: obstacle, shape: {type: box}}", "{name: b, kind: obstacle, shape: {type: open_box}}",
           "{name: b, kind: tet_solid, shape: {type: tet_box, resolution: [1, 1, 1]}}"}) {
    SCOPED_TRACE(s);
    const ConfigError e = config_error("time: {frames: 1}\nobjects:\n  - " + s + "\n");
    EXPECT_EQ(e.key_path(), "objects[0].shape.size") << e.what();
    EXPECT_TRUE(has(e.what(), "missing required key 'size'")) << e.what();
    EXPECT_EQ(e.line(), 3);
  }
}

// 2e9 nodes of 24 bytes each would be a 48 GB allocation before the first node is read; the file
// has 25 bytes (17 of header, one 8-byte node line).
TEST(InputBounds, TetgenCountsBeyondTheFileAreRefusedBeforeAllocating) {
  const fs::path d = dir("tetgen");
  write(d / "m.node", "2000000000 3 0 0\n1 0 0 0\n");
  write(d / "m.ele", "1 4 0\n1 1 2 3 4\n");
  const std::string m = error_of([&] { io::read_tetgen(d / "m.node"); });
  EXPECT_TRUE(has(m, "m.node:1")) << m;
  EXPECT_TRUE(has(m, "2000000000 nodes exceed what a 25-byte file can hold")) << m;
  // Four nodes in 4 lines fit their header.
  write(d / "ok.node", "4 3 0 0\n1 0 0 0\n2 1 0 0\n3 0 1 0\n4 0 0 1\n");
  write(d / "ok.ele", "1 4 0\n1 1 2 3 4\n");
  EXPECT_EQ(io::read_tetgen(d / "ok.node").v.size(), 4u);
}

TEST(InputBounds, GmshSectionsNeedTheirEndMarker) {
  const fs::path d = dir("gmsh");
  const std::string nodes = "$Nodes\n4\n1 0 0 0\n2 1 0 0\n3 0 1 0\n4 0 0 1\n";
  const std::string elems = "$Elements\n1\n1 4 0 1 2 3 4\n$EndElements\n";
  const std::string head = "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n";
  write(d / "ok.msh", head + nodes + "$EndNodes\n" + elems);
  EXPECT_EQ(io::read_gmsh(d / "ok.msh").t.size(), 1u);
  write(d / "bad.msh", head + nodes + elems);
  const std::string m = error_of([&] { io::read_gmsh(d / "bad.msh"); });
  EXPECT_TRUE(has(m, "bad.msh:10")) << m;
  EXPECT_TRUE(has(m, "expected $EndNodes")) << m;
  EXPECT_TRUE(has(m, "found '$Elements'")) << m;
  write(d / "bad2.msh", head + nodes + "$EndNodes\n$Elements\n1\n1 4 0 1 2 3 4\n");
  EXPECT_TRUE(has(error_of([&] { io::read_gmsh(d / "bad2.msh"); }), "$EndElements"));
}

TEST(InputBounds, RotationsNeedAnAxis) {
  ConfigError e = config_error(std::string(kSheet) + "    transform: {rotate_axis: [0, 0, 0], rotate_deg: 30}\n");
  EXPECT_EQ(e.key_path(), "objects[0].transform.rotate_axis") << e.what();
  EXPECT_TRUE(has(e.what(), "no direction")) << e.what();
  EXPECT_NO_THROW(
      io::load_scene_text(std::string(kSheet) + "    transform: {rotate_axis: [0, 0, 0]}\n", "scene.yaml", "."));
  e = config_error(obstacle("    motion: {axis: [0, 0, 0], angular_velocity: 1}\n"));
  EXPECT_EQ(e.key_path(), "objects[1].motion.axis") << e.what();
  e = config_error(
      obstacle("    keyframes:\n      - {time: 0}\n      - {time: 1, rotate_axis: [0, 0, 0], rotate_deg: 90}\n"));
  EXPECT_EQ(e.key_path(), "objects[1].keyframes[1].rotate_axis") << e.what();
}

// Keys are slerped the shorter way: 0° -> 270° would turn -90°, 0° -> 360° not at all.
TEST(InputBounds, KeyframeTurnsOf180DegreesOrMoreAreRefused) {
  auto keys = [](const std::string& a, const std::string& b) {
    return obstacle("    keyframes:\n      - {time: 0, " + a + "}\n      - {time: 1, " + b + "}\n");
  };
  for (const auto& [a, b, turn] : std::vector<std::tuple<std::string, std::string, std::string>>{
           {"rotate_deg: 0", "rotate_deg: 270", "270"},
           {"rotate_deg: 0", "rotate_axis: [1, 0, 0], rotate_deg: 360", "360"},
           {"rotate_deg: 90", "rotate_deg: -90", "-180"},
           {"rotate_axis: [0, 1, 0], rotate_deg: 100", "rotate_axis: [0, -1, 0], rotate_deg: 100", "200"}}) {
    SCOPED_TRACE(a + " -> " + b);
    const ConfigError e = config_error(keys(a, b));
    EXPECT_EQ(e.key_path(), "objects[1].keyframes[1].rotate_deg") << e.what();
    EXPECT_TRUE(has(e.what(), "turns " + turn + "°")) << e.what();
    EXPECT_TRUE(has(e.what(), "split it")) << e.what();
  }
  // Turns below 180° per key are what slerp interpolates: a full turn in three keys of 120°.
  EXPECT_NO_THROW(io::load_scene_text(obstacle("    keyframes:\n      - {time: 0}\n      - {time: 1, rotate_deg: "
                                               "120}\n      - {time: 2, rotate_deg: 240}\n      - {time: 3, "
                                               "rotate_deg: 359}\n"),
                                      "scene.yaml", "."));
  // Different axes: the keys are orientations; no single-axis turn to check.
  EXPECT_NO_THROW(
      io::load_scene_text(keys("rotate_axis: [1, 0, 0], rotate_deg: 90", "rotate_deg: 90"), "scene.yaml", "."));
}

TEST(InputBounds, NamesMustBeUtf8WithoutControlCharacters) {
  const std::string base = kSheet;
  for (const auto& [name, why] : std::vector<std::pair<std::string, std::string>>{
           {"\"a\\x85b\"", "U+0085"},    // NEL, written as UTF-8 by the YAML escape
           {"\"a\\u2028b\"", "U+2028"},  // line separator
           {"a\xff"
            "b",
            "not valid UTF-8"},               // a raw byte that is no UTF-8
           {"a\xc0\xaf", "not valid UTF-8"},  // overlong '/'
       }) {
    SCOPED_TRACE(why);
    std::string y = base;
    y.replace(y.find("name: sheet"), 11, "name: " + name);
    const ConfigError e = config_error(y);
    EXPECT_EQ(e.key_path(), "objects[0].name") << e.what();
    EXPECT_TRUE(has(e.what(), why)) << e.what();
    EXPECT_EQ(io::text_problem(io::printable(std::string(e.what()))), "") << e.what();  // the message itself is clean
  }
  std::string ok = base;
  ok.replace(ok.find("name: sheet"), 11, "name: \"Tuch \xc3\xbc \xe2\x9c\x93\"");
  EXPECT_NO_THROW(io::load_scene_text(ok, "scene.yaml", "."));
}

TEST(InputBounds, PhysicalValuesHaveBounds) {
  for (const auto& [key, value] :
       std::vector<std::pair<std::string, std::string>>{{"materials.default.stretch_compliance", "1e308"},
                                                        {"materials.default.bend_compliance", "1e7"},
                                                        {"materials.default.volume_compliance", "1e300"},
                                                        {"materials.default.shear_compliance", "1e300"},
                                                        {"materials.default.friction", "1e300"},
                                                        {"contact.stiffness", "1e300"},
                                                        {"contact.stiffness", "1e-300"},
                                                        {"contact.friction.static", "1e9"},
                                                        {"contact.friction.kinetic", "1e9"}}) {
    SCOPED_TRACE(key + "=" + value);
    const ConfigError e = config_error(kSheet, {key + "=" + value});
    EXPECT_EQ(e.key_path(), key) << e.what();
    EXPECT_TRUE(has(e.what(), "out of range") || has(e.what(), "must be")) << e.what();
  }
  EXPECT_NO_THROW(io::load_scene_text(kSheet, "scene.yaml", ".",
                                      {"materials.default.stretch_compliance=1e-2", "contact.stiffness=1e5"}));
}

// A cloth OBJ with `l` lines dropped them; a strand OBJ with faces dropped those.
TEST(InputBounds, MeshElementsTheObjectWouldDropAreRefused) {
  const fs::path d = dir("elements");
  write(d / "cloth.obj", "v 0 0 0\nv 1 0 0\nv 0 0 1\nf 1 2 3\nl 1 2\n");
  ConfigError e = config_error("objects:\n  - {name: c, kind: cloth, shape: {type: mesh, path: cloth.obj}}\n", {}, d);
  EXPECT_EQ(e.key_path(), "objects[0].shape.path") << e.what();
  EXPECT_TRUE(has(e.what(), "line 5")) << e.what();
  EXPECT_TRUE(has(e.what(), "`l` lines")) << e.what();
  write(d / "strand.obj", "v 0 0 0\nv 1 0 0\nv 0 0 1\nl 1 2 3\nf 1 2 3\n");
  e = config_error("objects:\n  - {name: s, kind: strand, shape: {type: mesh, path: strand.obj}}\n", {}, d);
  EXPECT_TRUE(has(e.what(), "line 5")) << e.what();
  write(d / "points.obj", "v 0 0 0\nv 1 0 0\nv 0 0 1\nf 1 2 3\np 1\n");
  e = config_error("objects:\n  - {name: c, kind: cloth, shape: {type: mesh, path: points.obj}}\n", {}, d);
  EXPECT_TRUE(has(e.what(), "line 5")) << e.what();
  write(d / "plain.obj", "v 0 0 0\nv 1 0 0\nv 0 0 1\nf 1 2 3\n");
  EXPECT_NO_THROW(
      io::load_scene_text("objects:\n  - {name: c, kind: cloth, shape: {type: mesh, path: plain.obj}}\n", "s.yaml", d));
}

TEST(InputBounds, MotionsThatEndBeforeTheyStartAreRefused) {
  std::string y = std::string(kSheet) +
                  "    pins:\n      - indices: [0]\n        motion: {velocity: [0, 1, 0], start: 5, end: 1}\n";
  ConfigError e = config_error(y);
  EXPECT_EQ(e.key_path(), "objects[0].pins[0].motion.end") << e.what();
  EXPECT_TRUE(has(e.what(), "before it starts")) << e.what();
  e = config_error(obstacle("    motion: {velocity: [1, 0, 0], start: 2, end: 1}\n"));
  EXPECT_EQ(e.key_path(), "objects[1].motion.end") << e.what();
}

TEST(InputBounds, SetValueHoldsOneDocument) {
  const std::string m =
      error_of([] { io::load_scene_text(kSheet, "scene.yaml", ".", {"contact.radius=0.02\n---\n0.5"}); });
  EXPECT_TRUE(has(m, "second YAML document")) << m;
  EXPECT_TRUE(has(m, "--set 'contact.radius=")) << m;
  EXPECT_NO_THROW(io::load_scene_text(kSheet, "scene.yaml", ".", {"contact.radius=0.02"}));
}

// Mesh errors quote the file's tokens: an escape sequence must not reach the terminal.
TEST(InputBounds, MeshErrorsDoNotEchoControlCharacters) {
  const fs::path d = dir("escape");
  write(d / "esc.obj", "v 0 0 \x1b[31mred\n");
  std::string m = error_of([&] { io::read_obj_mesh(d / "esc.obj"); });
  EXPECT_TRUE(has(m, "esc.obj:1")) << m;
  EXPECT_FALSE(has(m, "\x1b")) << m;
  EXPECT_TRUE(has(m, "\\x1b[31mred")) << m;
  write(d / "esc.off", "OFF\n1 0 0\n0 0 \x1b]0;title\x07\n");
  m = error_of([&] { io::read_off_mesh(d / "esc.off"); });
  EXPECT_FALSE(has(m, "\x1b")) << m;
  EXPECT_FALSE(has(m, "\x07")) << m;
  EXPECT_EQ(io::printable("ok \xc3\xa9 \x1b \xc2\x85"), "ok \xc3\xa9 \\x1b \\xc2\\x85");
}
