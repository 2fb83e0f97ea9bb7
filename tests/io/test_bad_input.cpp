// Every bad input gets one clear error naming the file (or the --set option), the key path and
// the line: integers beyond 32 bits, scenes too large for the machine, duplicate keys, extra
// documents, names that would break the OBJ frames, absurd magnitudes and degenerate meshes.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "ccfr/core/error.hpp"
#include "ccfr/io/scene_loader.hpp"
#include "ccfr/solvers/simulation.hpp"
#include "config_support.hpp"
#include "test_support.hpp"

using namespace ccfr;
using ccfr::test::config_error;
namespace fs = std::filesystem;

namespace {
const char* kBase = R"(scene: t
time:
  fps: 60
  frames: 2
contact:
  radius: 0.01
objects:
  - name: sheet
    kind: cloth
    shape: {type: grid, size: [1, 1], resolution: [4, 4]}
)";

std::string with(std::string y, const std::string& from, const std::string& to) {
  const auto pos = y.find(from);
  EXPECT_NE(pos, std::string::npos) << from;
  if (pos != std::string::npos) y.replace(pos, from.size(), to);
  return y;
}

std::string shape(const std::string& s) { return with(kBase, "{type: grid, size: [1, 1], resolution: [4, 4]}", s); }

bool has(const ConfigError& e, const std::string& text) {
  return std::string(e.what()).find(text) != std::string::npos;
}

fs::path mesh_dir() {
  const fs::path d = fs::temp_directory_path() / "ccfr_test_bad_meshes";
  fs::create_directories(d);
  return d;
}
}  // namespace

TEST(BadInput, IntegersBeyond32BitsAreRangeErrorsWithKeyAndLine) {
  auto e = config_error(with(kBase, "  frames: 2", "  frames: 2\n  substeps: 3000000000"));
  EXPECT_EQ(e.key_path(), "time.substeps");
  EXPECT_EQ(e.line(), 5);
  EXPECT_TRUE(has(e, "out of range")) << e.what();
  EXPECT_TRUE(has(e, "in [1, 10000]")) << e.what();  // time.substeps' own bound, within int
  // Beyond 64 bits too.
  e = config_error(with(kBase, "  frames: 2", "  frames: 99999999999999999999999"));
  EXPECT_EQ(e.key_path(), "time.frames");
  EXPECT_TRUE(has(e, "out of range")) << e.what();

  e = config_error(kBase, {"time.substeps=3000000000"});
  EXPECT_EQ(e.key_path(), "time.substeps");
  EXPECT_TRUE(has(e, "--set time.substeps=3000000000")) << e.what();

  e = config_error(std::string(kBase) + "    pins:\n      - indices: [0, 3000000000]\n");
  EXPECT_EQ(e.key_path(), "objects[0].pins[0].indices[1]");
  EXPECT_EQ(e.line(), 12);
}

TEST(BadInput, GeneratorResolutionsThatOverflowIndicesAreRefused) {
  auto e = config_error(shape("{type: grid, size: [1, 1], resolution: [2147483647, 2]}"));
  EXPECT_EQ(e.key_path(), "objects[0].shape");
  EXPECT_EQ(e.line(), 10);
  EXPECT_TRUE(has(e, "32-bit")) << e.what();
  std::string y =
      with(shape("{type: tet_box, size: [1, 1, 1], resolution: [2147483647, 1, 1]}"), "kind: cloth", "kind: tet_solid");
  e = config_error(y);
  EXPECT_EQ(e.key_path(), "objects[0].shape");
  EXPECT_TRUE(has(e, "32-bit")) << e.what();
  y = with(shape("{type: particles, counts: [2147483647, 2147483647, 2147483647]}"), "kind: cloth", "kind: particles");
  e = config_error(y);
  EXPECT_TRUE(has(e, "32-bit")) << e.what();
}

TEST(BadInput, ScenesLargerThanTheMemoryAreRefusedBeforeAllocating) {
  // 4e8 vertices, 8e8 faces: indices fit, memory does not (hundreds of GB by any estimate).
  const auto e = config_error(shape("{type: grid, size: [1, 1], resolution: [20000, 20000]}"));
  EXPECT_EQ(e.key_path(), "objects[0].shape");
  EXPECT_EQ(e.line(), 10);
  EXPECT_TRUE(has(e, "of memory")) << e.what();
  EXPECT_TRUE(has(e, "available (MemAvailable)")) << e.what();
  EXPECT_TRUE(has(e, "400040001 vertices")) << e.what();
}

// A fine mesh (40962 vertices, edges ~8 mm, contact range 20.5 mm) as a shell crowds every vertex
// with ~6 neighbours' pairs: estimated above 1 GB. The same mesh as a rigid body or an obstacle
// never pairs with itself, so only its elements count (98 MB) and it loads under that limit.
TEST(BadInput, MemoryEstimateChargesNoSelfPairsToRigidsAndObstacles) {
  const std::string ball = with(shape("{type: sphere, radius: 0.5, subdivisions: 6}"), "scene: t\n",
                                "scene: t\nmax_memory: 1\nmaterials: {m: {density: 1000}}\n");
  for (const char* kind : {"kind: rigid\n    material: m", "kind: obstacle"}) {
    const std::string y = with(ball, "kind: cloth", kind);
    EXPECT_NO_THROW(io::load_scene_text(y, "scene.yaml", ".")) << kind;
  }
  const std::string shell = with(ball, "kind: cloth", "kind: shell");
  auto e = config_error(shell);
  EXPECT_EQ(e.key_path(), "objects[0].shape");
  EXPECT_TRUE(has(e, "'sheet' (shell, 40962 vertices)")) << e.what();
  EXPECT_TRUE(has(e, "more than the 1.0 GB of max_memory")) << e.what();
  EXPECT_TRUE(has(e, "--max-memory")) << e.what();
  // Next to a rigid copy, the refusal names both objects and what each costs.
  const std::string two = shell +
                          "  - name: body\n    kind: rigid\n    material: m\n"
                          "    shape: {type: sphere, radius: 0.5, subdivisions: 6}\n"
                          "    transform: {translate: [3, 0, 0]}\n";
  const std::string rigid_first = with(with(two, "kind: shell", "kind: rigid\n    material: m"),
                                       "  - name: body\n    kind: rigid", "  - name: body\n    kind: shell");
  e = config_error(rigid_first);
  EXPECT_EQ(e.key_path(), "objects[1].shape");
  EXPECT_TRUE(has(e, "'sheet' (rigid, 40962 vertices) 98 MB, 'body' (shell, 40962 vertices)")) << e.what();
  // Raised knowingly (what `ccfr run --max-memory` sets): the shell loads.
  EXPECT_NO_THROW(io::load_scene_text(shell, "scene.yaml", ".", {"max_memory=1000"}));
  e = config_error(shell, {"max_memory=-1"});
  EXPECT_EQ(e.key_path(), "max_memory");
}

TEST(BadInput, DuplicateKeysAreErrors) {
  auto e = config_error(with(kBase, "  fps: 60\n", "  fps: 60\n  fps: -5\n"));
  EXPECT_EQ(e.key_path(), "time.fps");
  EXPECT_EQ(e.line(), 4);
  EXPECT_TRUE(has(e, "duplicate key 'fps'")) << e.what();
  EXPECT_TRUE(has(e, "line 3")) << e.what();
  e = config_error(std::string(kBase) + "time: {fps: 30}\n");
  EXPECT_EQ(e.key_path(), "time");
  EXPECT_EQ(e.line(), 11);
  e = config_error(std::string(kBase) + "materials:\n  silk: {}\n  silk: {density: 2}\n");
  EXPECT_EQ(e.key_path(), "materials.silk");
  EXPECT_EQ(e.line(), 13);
  e = config_error(shape("{type: grid, type: sphere, size: [1, 1], resolution: [4, 4]}"));
  EXPECT_EQ(e.key_path(), "objects[0].shape.type");
}

TEST(BadInput, ExtraDocumentsAndNonStringKeysAreErrors) {
  auto e = config_error(std::string(kBase) + "---\nscene: other\n");
  EXPECT_EQ(e.line(), 12);
  EXPECT_TRUE(has(e, "second one")) << e.what();
  // A document marker at the start, or a trailing empty document, is harmless.
  EXPECT_NO_THROW(io::load_scene_text(std::string("---\n") + kBase + "---\n", "scene.yaml", "."));
  e = config_error(with(kBase, "  fps: 60", "  [fps]: 60"));
  EXPECT_EQ(e.key_path(), "time");
  EXPECT_EQ(e.line(), 3);
  EXPECT_TRUE(has(e, "keys must be strings")) << e.what();
}

// yaml-cpp 0.7's LoadAll never returns on a token no node starts with (found by fuzzing: minutes
// and gigabytes for one line); NUL bytes do the same. Both must be fast, clear syntax errors.
TEST(BadInput, TokensNoNodeStartsWithAndControlBytesAreQuickErrors) {
  auto e = config_error(",objects: [{name: c, kind: cloth}]\n");
  EXPECT_EQ(e.line(), 1);
  EXPECT_TRUE(has(e, "unexpected ','")) << e.what();
  e = config_error(std::string(kBase) + "]\n");
  EXPECT_TRUE(has(e, "YAML syntax error")) << e.what();
  e = config_error(with(kBase, "time:", std::string("# a comment with a NUL \0 byte\ntime:", 35)));
  EXPECT_EQ(e.line(), 2);
  EXPECT_TRUE(has(e, "control byte 0x00")) << e.what();
  e = config_error(with(kBase, "scene: t", "scene: t\x1b[31m"));
  EXPECT_TRUE(has(e, "control byte 0x1b")) << e.what();
  // Tabs inside a comment and CRLF line ends are text.
  std::string crlf;
  for (const char c : std::string(kBase)) crlf += c == '\n' ? std::string("\r\n") : std::string(1, c);
  EXPECT_NO_THROW(io::load_scene_text(crlf + "#\ttab\r\n", "scene.yaml", "."));
  e = config_error(std::string(kBase) + "#" + std::string(size_t{5} << 20, 'x') + "\n");
  EXPECT_TRUE(has(e, "limited to 4 MiB")) << e.what();
}

TEST(BadInput, UnterminatedQuoteIsASyntaxErrorWithItsLine) {
  auto e = config_error(with(kBase, "  - name: sheet", "  - name: \"sheet"));
  EXPECT_EQ(e.line(), 8);
  EXPECT_TRUE(has(e, "unterminated")) << e.what();
  e = config_error(with(kBase, "scene: t", "scene: 't"));
  EXPECT_EQ(e.line(), 1);
  EXPECT_TRUE(has(e, "unterminated")) << e.what();
  // Escaped quotes and multi-line quoted strings that do close are fine.
  EXPECT_NO_THROW(io::load_scene_text(with(kBase, "scene: t", "scene: \"a \\\" b\""), "scene.yaml", "."));
  EXPECT_NO_THROW(io::load_scene_text(with(kBase, "scene: t", "scene: 'it''s\n  two lines'"), "scene.yaml", "."));
}

TEST(BadInput, NamesThatWouldBreakTheObjFramesAreRefused) {
  for (const std::string bad : {"\"a\\nb\"", "\"a\\tb\"", "'   '", "''", "' lead'"}) {
    SCOPED_TRACE(bad);
    const auto e = config_error(with(kBase, "name: sheet", "name: " + bad));
    EXPECT_EQ(e.key_path(), "objects[0].name");
    EXPECT_EQ(e.line(), 8);
    EXPECT_TRUE(has(e, "OBJ")) << e.what();
  }
  const auto e = config_error(with(kBase, "scene: t", "scene: \"a\\x01b\""));
  EXPECT_EQ(e.key_path(), "scene");
  EXPECT_EQ(e.line(), 1);
  EXPECT_TRUE(has(e, "control character")) << e.what();
  EXPECT_TRUE(has(e, "\\x01")) << e.what();
  EXPECT_NO_THROW(io::load_scene_text(with(kBase, "name: sheet", "name: 'my sheet'"), "scene.yaml", "."));
}

TEST(BadInput, NonPositiveTetBoxSizesAndAbsurdMagnitudesAreRangeErrors) {
  const std::string tet = with(shape("{type: tet_box, size: [1, -1, 1]}"), "kind: cloth", "kind: tet_solid");
  auto e = config_error(tet);
  EXPECT_EQ(e.key_path(), "objects[0].shape.size[1]");
  EXPECT_EQ(e.line(), 10);
  struct Case {
    std::string extra, path;
  };
  const std::vector<Case> cases = {
      {"    transform: {translate: [1e300, 0, 0]}\n", "objects[0].transform.translate[0]"},
      {"    transform: {scale: 1e300}\n", "objects[0].transform.scale"},
      {"    velocity: [0, -1e300, 0]\n", "objects[0].velocity[1]"},
      {"    motion: {angular_velocity: 1e300}\n", "objects[0].motion.angular_velocity"},
  };
  for (const auto& c : cases) {
    e = config_error(std::string(kBase) + c.extra);
    EXPECT_EQ(e.key_path(), c.path) << e.what();
    EXPECT_EQ(e.line(), 11) << e.what();
    EXPECT_TRUE(has(e, "out of range")) << e.what();
  }
  e = config_error(shape("{type: grid, size: [1e300, 1], resolution: [4, 4]}"));
  EXPECT_EQ(e.key_path(), "objects[0].shape.size[0]");
  e = config_error(with(kBase, "  fps: 60", "  fps: 60\n  gravity: [0, -1e300, 0]"));
  EXPECT_EQ(e.key_path(), "time.gravity[1]");
}

TEST(BadInput, UnsupportedMeshFormatsNameTheExtension) {
  for (const std::string ext : {"gltf", "STL"}) {
    std::ofstream(mesh_dir() / ("m." + ext)) << "whatever\n";
    const auto e = config_error(shape("{type: mesh, path: m." + ext + "}"), {}, mesh_dir());
    EXPECT_EQ(e.key_path(), "objects[0].shape.path");
    EXPECT_EQ(e.line(), 10);
    EXPECT_TRUE(has(e, "unsupported mesh format '." + ext + "' (supported: .obj, .off, .node, .ele, .msh)"))
        << e.what();
  }
  std::ofstream(mesh_dir() / "ok.OBJ") << "v 0 0 0\nv 1 0 0\nv 0 0 1\nf 1 2 3\n";
  EXPECT_NO_THROW(io::load_scene_text(shape("{type: mesh, path: ok.OBJ}"), "scene.yaml", mesh_dir()));
}

TEST(BadInput, DegenerateMeshesNameFileAndFace) {
  const std::string quad = "v 0 0 0\nv 1 0 0\nv 1 0 1\nv 0 0 1\n";
  struct Case {
    std::string file, obj, expect;
  };
  const std::vector<Case> cases = {
      {"repeat.obj", quad + "f 1 2 3\nf 1 3 3\n", "face 2 (line 6) repeats vertex 3"},
      {"flat.obj", "v 0 0 0\nv 1 0 0\nv 2 0 0\nv 0 0 1\nf 1 2 4\nf 1 2 3\n", "face 2 (line 6) has zero area"},
      {"twice.obj", quad + "f 1 2 3\nf 1 3 4\nf 3 1 2\n", "face 3 (line 7) repeats face 1 (line 5)"},
  };
  for (const auto& c : cases) {
    SCOPED_TRACE(c.file);
    std::ofstream(mesh_dir() / c.file) << c.obj;
    const auto e = config_error(shape("{type: mesh, path: " + c.file + "}"), {}, mesh_dir());
    EXPECT_EQ(e.key_path(), "objects[0].shape.path");
    EXPECT_EQ(e.line(), 10);
    EXPECT_TRUE(has(e, c.file)) << e.what();
    EXPECT_TRUE(has(e, c.expect)) << e.what();
  }
}

TEST(BadInput, NonManifoldAndOpenMeshes) {
  // Three triangles on the edge 1-2: non-manifold. An error for a rigid body, a warning for cloth.
  std::ofstream(mesh_dir() / "fin.obj") << "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 -1 0\nv 0 0 1\nf 1 2 3\nf 2 1 4\nf 1 2 5\n";
  const std::string rigid = with(shape("{type: mesh, path: fin.obj}"), "kind: cloth", "kind: rigid");
  auto e = config_error(rigid, {}, mesh_dir());
  EXPECT_EQ(e.key_path(), "objects[0].shape.path");
  EXPECT_TRUE(has(e, "fin.obj")) << e.what();
  EXPECT_TRUE(has(e, "non-manifold")) << e.what();
  EXPECT_TRUE(has(e, "face 3 (line 8)")) << e.what();
  {
    test::ExpectWarnings w;
    EXPECT_NO_THROW(io::load_scene_text(shape("{type: mesh, path: fin.obj}"), "scene.yaml", mesh_dir()));
  }
  // An open surface as a rigid body: its mass would depend on where it is placed.
  std::ofstream(mesh_dir() / "open.obj") << "v 0 0 0\nv 1 0 0\nv 1 0 1\nv 0 0 1\nf 1 2 3\nf 1 3 4\n";
  e = config_error(with(shape("{type: mesh, path: open.obj}"), "kind: cloth", "kind: rigid"), {}, mesh_dir());
  EXPECT_TRUE(has(e, "closed surface")) << e.what();
  EXPECT_TRUE(has(e, "open.obj")) << e.what();
  e = config_error(with(kBase, "kind: cloth", "kind: rigid"));
  EXPECT_EQ(e.key_path(), "objects[0].shape.type");
  EXPECT_TRUE(has(e, "closed surface")) << e.what();
  // Closed generated shapes stay valid rigid bodies.
  EXPECT_NO_THROW(
      io::load_scene_text(with(shape("{type: sphere, radius: 0.2}"), "kind: cloth", "kind: rigid"), "scene.yaml", "."));
  EXPECT_NO_THROW(
      io::load_scene_text(with(shape("{type: cylinder}"), "kind: cloth", "kind: rigid"), "scene.yaml", "."));
}

TEST(BadInput, OverrideMistakesBlameTheRightSource) {
  // A `time` that is not a map is the scene file's mistake, even when an internal override such
  // as `--frames` (time.frames=N) reaches into it.
  auto e = config_error(with(kBase, "time:\n  fps: 60\n  frames: 2\n", "time: 5\n"), {"time.frames=3"});
  EXPECT_EQ(e.file(), "scene.yaml");
  EXPECT_EQ(e.key_path(), "time");
  EXPECT_EQ(e.line(), 2);
  EXPECT_FALSE(has(e, "--set")) << e.what();
  // A --set that reaches into a string is the option's mistake.
  try {
    io::load_scene_text(kBase, "scene.yaml", ".", {"scene.name=x"});
    FAIL();
  } catch (const Error& err) {
    EXPECT_NE(std::string(err.what()).find("--set 'scene.name=x'"), std::string::npos) << err.what();
  }
}

TEST(BadInput, SetMistakesBlameTheSetOption) {
  // The shape is fine in the file; the --set kind is what does not fit it.
  auto e = config_error(kBase, {"objects.sheet.kind=strand"});
  EXPECT_EQ(e.key_path(), "objects[0].kind");
  EXPECT_TRUE(has(e, "--set objects.sheet.kind=strand")) << e.what();
  e = config_error(kBase, {"objects.sheet.kind=rigid"});
  EXPECT_TRUE(has(e, "--set objects.sheet.kind=rigid")) << e.what();
  EXPECT_TRUE(has(e, "closed surface")) << e.what();
  e = config_error(with(kBase, "  radius: 0.01", "  radius: 0.01\n  friction: {kinetic: 0.5}"),
                   {"contact.friction.static=0.2"});
  EXPECT_TRUE(has(e, "--set contact.friction.static=0.2")) << e.what();
}

// Counts that multiply (substeps x subdivision x iterations, 4 x iterations) are bounded so that no
// product overflows int and no frame runs unbounded; iterations 536870912 made 4 x iterations
// negative and crashed in Simulation::record_lag.
TEST(BadInput, CountsAreBoundedSoNoProductOverflows) {
  const auto time_key = [](const std::string& kv) { return with(kBase, "  frames: 2", "  frames: 2\n  " + kv); };
  struct Case {
    const char* kv;
    const char* key;
  };
  for (const Case c :
       {Case{"iterations: 536870912", "time.iterations"}, Case{"substeps: 2147483647", "time.substeps"},
        Case{"xpbd_sweeps: 2147483647", "time.xpbd_sweeps"}, Case{"frames: 2147483647", "time.frames"}}) {
    const std::string y =
        c.kv == std::string("frames: 2147483647") ? with(kBase, "  frames: 2", "  frames: 2147483647") : time_key(c.kv);
    const auto e = config_error(y);
    EXPECT_EQ(e.key_path(), c.key) << e.what();
    EXPECT_EQ(e.file(), "scene.yaml");
    EXPECT_TRUE(has(e, "in [")) << e.what();
  }
  // From --set (Python's overrides take the same path).
  auto e = config_error(kBase, {"time.iterations=536870912"});
  EXPECT_EQ(e.key_path(), "time.iterations");
  EXPECT_TRUE(has(e, "--set time.iterations=536870912")) << e.what();
  // A maximum below the nominal count.
  e = config_error(time_key("iterations: 1000\n  max_iterations: 10"));
  EXPECT_EQ(e.key_path(), "time.max_iterations");
  EXPECT_EQ(e.line(), 6);
  EXPECT_TRUE(has(e, "below time.iterations (1000)")) << e.what();
  // Each count within its bound, the product past int: named with the keys to lower.
  e = config_error(time_key("substeps: 10000\n  max_subdivision: 4096\n  max_iterations: 4096"));
  EXPECT_EQ(e.key_path(), "time.substeps");
  EXPECT_TRUE(has(e, "time.max_subdivision")) << e.what();
  EXPECT_TRUE(has(e, "more than 2147483647")) << e.what();
  // A registered solver's count is bounded too.
  e = config_error(with(kBase, "  radius: 0.01",
                        "  radius: 0.01\n  solver: post_process\n  post_process: {sweeps: "
                        "2147483647}"));
  EXPECT_EQ(e.key_path(), "contact.post_process.sweeps");
  // The largest counts allowed still load.
  EXPECT_NO_THROW(io::load_scene_text(time_key("iterations: 1024\n  xpbd_sweeps: 10000"), "scene.yaml", "."));
}

// Magnitudes that are typos rather than scenes: each refused naming its key.
TEST(BadInput, TinyFpsScaleAndAnAuditToleranceOfOneAreRangeErrors) {
  auto e = config_error(with(kBase, "  fps: 60", "  fps: 1e-300"));
  EXPECT_EQ(e.key_path(), "time.fps");
  EXPECT_EQ(e.line(), 3);
  e = config_error(with(kBase, "resolution: [4, 4]}", "resolution: [4, 4]}\n    transform: {scale: 1e-300}"));
  EXPECT_EQ(e.key_path(), "objects[0].transform.scale");
  // debug.audit_tolerance: the range the audit accepts at run time, [0, 1).
  e = config_error(std::string(kBase) + "debug: {audit: every_frame, audit_tolerance: 1}\n");
  EXPECT_EQ(e.key_path(), "debug.audit_tolerance");
  EXPECT_TRUE(has(e, "[0, 1)")) << e.what();
}

// Keys that would do nothing for the object they are on: refused naming the key and the kind.
TEST(BadInput, MotionOnADeformableAndTetgenSettingsWithoutTetgenAreRefused) {
  auto e = config_error(with(kBase, "resolution: [4, 4]}", "resolution: [4, 4]}\n    motion: {velocity: [0, 1, 0]}"));
  EXPECT_EQ(e.key_path(), "objects[0].motion");
  EXPECT_EQ(e.line(), 11);
  EXPECT_TRUE(has(e, "only obstacles follow `motion`")) << e.what();
  EXPECT_TRUE(has(e, "pins[].motion")) << e.what();
  const fs::path obj = mesh_dir() / "tri.obj";
  std::ofstream(obj) << "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
  e = config_error(shape("{type: mesh, path: " + obj.string() + ", quality: 1.5}"));
  EXPECT_EQ(e.key_path(), "objects[0].shape.quality");
  EXPECT_TRUE(has(e, "applies only to a tet_solid")) << e.what();
  EXPECT_NO_THROW(io::load_scene_text(shape("{type: mesh, path: " + obj.string() + "}"), "scene.yaml", "."));
}

// Two pin groups moving one vertex differently: only the last would act. Overlapping groups that
// hold it alike stay fine.
TEST(BadInput, AVertexInTwoPinGroupsMovingDifferentlyIsRefused) {
  const std::string pins = std::string(kBase) +
                           "    pins:\n"
                           "      - {indices: [0, 1], motion: {velocity: [0, 1, 0]}}\n"
                           "      - {indices: [1, 2], motion: {velocity: [0, -1, 0]}}\n";
  const auto e = config_error(pins);
  EXPECT_EQ(e.key_path(), "objects[0].pins[1]");
  EXPECT_EQ(e.line(), 13);
  EXPECT_TRUE(has(e, "vertex 1 is also in objects[0].pins[0]")) << e.what();
  const std::string alike =
      std::string(kBase) +
      "    pins:\n      - {indices: [0, 1]}\n      - {box_min: [-1, -1, -1], box_max: [1, 1, 1]}\n";
  EXPECT_NO_THROW(io::load_scene_text(alike, "scene.yaml", "."));
}

// A NUL in a key (YAML's "\0") cut the printed message at it; control characters show as \xNN.
TEST(BadInput, ControlCharactersInKeysArePrintedEscaped) {
  const auto e = config_error(with(kBase, "  frames: 2", "  frames: 2\n  \"ab\\0cd\": 1"));
  EXPECT_EQ(e.key_path(), "time.ab\\x00cd");
  EXPECT_TRUE(has(e, "unknown key 'ab\\x00cd'")) << e.what();
  EXPECT_EQ(std::string(e.what()).find('\0'), std::string::npos);
}

/// A component's own check when the simulation starts (contact.dat.query_radius against the
/// offset and radius, which the schema cannot compare) names the file, key path and line like
/// the schema's errors, or the --set that gave the value; other errors pass unchanged.
TEST(BadInput, LateComponentChecksNameFileKeyAndLine) {
  const auto start = [](const io::LoadedScene& s) {
    try {
      Simulation sim(s.scene);
    } catch (const Error& e) {
      io::rethrow_located(s, e);
    }
  };
  const std::string y =
      with(kBase, "  radius: 0.01\n", "  radius: 0.01\n  solver: dat\n  dat: {query_radius: 1.0e300}\n");
  try {
    start(io::load_scene_text(y, "scene.yaml", "."));
    ADD_FAILURE() << "query_radius 1e300 was accepted";
  } catch (const ConfigError& e) {
    EXPECT_EQ(e.file(), "scene.yaml");
    EXPECT_EQ(e.key_path(), "contact.dat.query_radius");
    EXPECT_EQ(e.line(), 8);  // the line of `dat: {query_radius: ...}` in y
    EXPECT_TRUE(has(e, "scene.yaml:8: 'contact.dat.query_radius': 1e+300 must be > contact.offset")) << e.what();
  }
  try {
    start(io::load_scene_text(kBase, "scene.yaml", ".", {"contact.solver=dat", "contact.dat.query_radius=1e-300"}));
    ADD_FAILURE() << "query_radius 1e-300 was accepted";
  } catch (const ConfigError& e) {
    EXPECT_EQ(e.file(), "command line (--set contact.dat.query_radius=1e-300)");
    EXPECT_EQ(e.key_path(), "contact.dat.query_radius");
  }
  const auto s = io::load_scene_text(kBase, "scene.yaml", ".");
  try {
    try {
      throw Error("no key here: something else");
    } catch (const Error& e) {
      io::rethrow_located(s, e);
    }
  } catch (const ConfigError& e) {
    ADD_FAILURE() << "relabelled: " << e.what();
  } catch (const Error& e) {
    EXPECT_STREQ(e.what(), "no key here: something else");
  }
}
