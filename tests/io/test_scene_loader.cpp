#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <regex>

#include "ccfr/core/error.hpp"
#include "ccfr/io/obj.hpp"
#include "ccfr/io/scene_loader.hpp"
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

}  // namespace

TEST(SceneLoader, MinimalSceneFillsDefaults) {
  const auto s = io::load_scene_text(kBase, "scene.yaml", ".");
  EXPECT_EQ(s.scene.params.scene_name, "t");
  EXPECT_EQ(s.scene.topo.num_vertices(), 25);
  EXPECT_DOUBLE_EQ(s.scene.params.contact.radius, 0.01);
  EXPECT_DOUBLE_EQ(s.scene.params.contact.offset, 0.01);  // default
  EXPECT_EQ(s.scene.params.contact.solver, "ccfr");
  EXPECT_EQ(s.scene.params.time.frames, 2);
  // Masses: areal density 0.1 (default) over 1 m².
  double m = 0;
  for (double mi : s.scene.state.mass) m += mi;
  EXPECT_NEAR(m, 0.1, 1e-12);
  EXPECT_NE(s.resolved_json.find("\"repulsion_range\": 0.0005"), std::string::npos) << s.resolved_json;
}

TEST(SceneLoader, MisspeltKeyNamesKeyLineAndSuggestion) {
  std::string y = kBase;
  y.replace(y.find("  radius:"), 9, "  raduis:");
  const auto e = config_error(y);
  EXPECT_EQ(e.key_path(), "contact.raduis");
  EXPECT_EQ(e.line(), 6);
  EXPECT_NE(e.detail().find("did you mean 'radius'"), std::string::npos) << e.what();
  EXPECT_EQ(e.file(), "scene.yaml");
}

TEST(SceneLoader, WrongTypesAndRangesAreRejectedWithTheirLine) {
  struct Case {
    std::string from, to, path;
    int line;
  };
  const std::vector<Case> cases = {
      {"  fps: 60", "  fps: 0", "time.fps", 3},  // dt <= 0
      {"  fps: 60", "  fps: -30", "time.fps", 3},
      {"  fps: 60", "  fps: sixty", "time.fps", 3},            // wrong type
      {"  frames: 2", "  frames: 2.5", "time.frames", 4},      // integer expected
      {"  radius: 0.01", "  radius: 0", "contact.radius", 6},  // r <= 0
      {"  radius: 0.01", "  radius: [1, 2]", "contact.radius", 6},
      {"  radius: 0.01", "  radius: .nan", "contact.radius", 6},  // NaN
      {"kind: cloth", "kind: clothe", "objects[0].kind", 9},      // unknown choice
      {"size: [1, 1]", "size: [1]", "objects[0].shape.size", 10},
      {"resolution: [4, 4]", "resolution: [0, 4]", "objects[0].shape.resolution[0]", 10},
  };
  for (const auto& c : cases) {
    std::string y = kBase;
    const auto pos = y.find(c.from);
    ASSERT_NE(pos, std::string::npos) << c.from;
    y.replace(pos, c.from.size(), c.to);
    const auto e = config_error(y);
    EXPECT_EQ(e.key_path(), c.path) << e.what();
    EXPECT_EQ(e.line(), c.line) << e.what();
  }
}

TEST(SceneLoader, NegativeOffsetAndDensityAreRejected) {
  std::string y = std::string(kBase) + "materials:\n  heavy: {density: -1}\n";
  auto e = config_error(y);
  EXPECT_EQ(e.key_path(), "materials.heavy.density");
  EXPECT_EQ(e.line(), 12);
  y = kBase;
  y.insert(y.find("objects:"), "  offset: -0.001\n");
  e = config_error(y);
  EXPECT_EQ(e.key_path(), "contact.offset");
  EXPECT_EQ(e.line(), 7);
}

TEST(SceneLoader, MissingMeshFileNamesThePath) {
  std::string y = kBase;
  y.replace(y.find("{type: grid, size: [1, 1], resolution: [4, 4]}"), 46, "{type: mesh, path: no/such/file.obj}");
  const auto e = config_error(y);
  EXPECT_EQ(e.key_path(), "objects[0].shape.path");
  EXPECT_NE(e.detail().find("no/such/file.obj"), std::string::npos) << e.what();
  EXPECT_EQ(e.line(), 10);
}

TEST(SceneLoader, BrokenMeshFileIsAConfigError) {
  const fs::path dir = fs::temp_directory_path() / "ccfr_test_broken_mesh";
  fs::create_directories(dir);
  std::ofstream(dir / "bad.obj") << "v 0 0 0\nv 1 0 0\nf 1 2 7\n";
  std::string y = kBase;
  y.replace(y.find("{type: grid, size: [1, 1], resolution: [4, 4]}"), 46, "{type: mesh, path: bad.obj}");
  try {
    io::load_scene_text(y, "scene.yaml", dir);
    FAIL() << "expected an error";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("bad.obj:3"), std::string::npos) << e.what();
  }
}

TEST(SceneLoader, MissingRequiredAndUnknownMaterial) {
  std::string y = kBase;
  y.replace(y.find("    kind: cloth\n"), 16, "");
  auto e = config_error(y);
  EXPECT_EQ(e.key_path(), "objects[0].kind");
  y = kBase;
  y.insert(y.find("    shape:"), "    material: silk\n");
  e = config_error(y);
  EXPECT_EQ(e.key_path(), "objects[0].material");
  EXPECT_EQ(e.line(), 10);
}

TEST(SceneLoader, ShapeKindMismatchAndDuplicateNames) {
  std::string y = kBase;
  y.replace(y.find("kind: cloth"), 11, "kind: strand");
  auto e = config_error(y);
  EXPECT_EQ(e.key_path(), "objects[0].shape.type");
  y = std::string(kBase) + "  - name: sheet\n    kind: particles\n    shape: {type: particles, counts: [1, 1, 1]}\n";
  e = config_error(y);
  EXPECT_EQ(e.key_path(), "objects[1].name");
  EXPECT_EQ(e.line(), 11);
}

TEST(SceneLoader, SetOverridesAnyKeyAndIsValidated) {
  auto s = io::load_scene_text(
      kBase, "scene.yaml", ".",
      {"contact.offset=0.002", "objects.sheet.shape.resolution=[2, 3]", "objects[0].velocity=[0, 1, 0]"});
  EXPECT_DOUBLE_EQ(s.scene.params.contact.offset, 0.002);
  EXPECT_EQ(s.scene.topo.num_vertices(), 12);
  EXPECT_DOUBLE_EQ(s.scene.state.v[0].y(), 1.0);
  auto e = config_error(kBase, {"contact.radius=-1"});
  EXPECT_EQ(e.key_path(), "contact.radius");
  EXPECT_NE(std::string(e.what()).find("--set contact.radius=-1"), std::string::npos) << e.what();
  e = config_error(kBase, {"contact.raduis=1"});
  EXPECT_NE(e.detail().find("did you mean 'radius'"), std::string::npos);
  EXPECT_THROW(io::load_scene_text(kBase, "scene.yaml", ".", {"objects.5.name=x"}), Error);
  EXPECT_THROW(io::load_scene_text(kBase, "scene.yaml", ".", {"novalue"}), Error);
}

// A map value merges into the map there key by key, as one key path per leaf would: `time`
// keeps its frames (2, against the default 1), the grid its size. A value naming another variant replaces it whole: a
// mesh shape's keys would not belong to a sphere.
TEST(SceneLoader, SetWithAMapValueMergesKeyByKey) {
  const std::string y = std::string(kBase) + "    velocity: [0, 2, 0]\n";
  auto s = io::load_scene_text(
      y, "scene.yaml", ".",
      {"time={substeps: 3}", "objects.sheet={velocity: [1, 0, 0]}", "objects[0].shape={resolution: [2, 3]}"});
  EXPECT_EQ(s.scene.params.time.frames, 2);
  EXPECT_EQ(s.scene.params.time.substeps, 3);
  EXPECT_EQ(s.scene.topo.num_vertices(), 12);
  EXPECT_DOUBLE_EQ(s.scene.state.v[0].x(), 1.0);
  double xmin = 1e9, xmax = -1e9;
  for (const auto& p : s.scene.state.x) xmin = std::min(xmin, p.x()), xmax = std::max(xmax, p.x());
  EXPECT_NEAR(xmax - xmin, 1.0, 1e-12);  // size [1, 1] kept
  s = io::load_scene_text(kBase, "scene.yaml", ".", {"objects.sheet.shape={type: grid, resolution: [3, 3]}"});
  EXPECT_EQ(s.scene.topo.num_vertices(), 16);  // 3 x 3 cells
  // Another variant replaces: a sphere has no `size`, which a merge would have kept (and refused).
  s = io::load_scene_text(kBase, "scene.yaml", ".", {"objects.sheet.shape={type: sphere, radius: 0.1}"});
  EXPECT_GT(s.scene.topo.num_vertices(), 12);
}

TEST(SceneLoader, PinsByBoxAndIndicesBecomeKinematic) {
  std::string y = std::string(kBase) +
                  "    pins:\n      - indices: [0, 4]\n      - box_min: [-1, -1, 0.49]\n        box_max: [1, 1, 1]\n";
  const auto s = io::load_scene_text(y, "scene.yaml", ".");
  Index pinned = 0;
  for (double w : s.scene.state.inv_mass) pinned += w == 0.0;
  EXPECT_EQ(pinned, 2 + 5);  // vertices 0 and 4 lie on the z = -0.5 row; the z = +0.5 row has 5 more
  y = std::string(kBase) + "    pins:\n      - indices: [25]\n";
  const auto e = config_error(y);
  EXPECT_EQ(e.key_path(), "objects[0].pins[0].indices[0]");
}

TEST(SceneLoader, SyntaxErrorHasALine) {
  const auto e = config_error("time:\n  fps: [1, 2\n");
  EXPECT_GT(e.line(), 0);
}

TEST(SceneLoader, EveryConfigInTheRepositoryLoads) {
  const fs::path configs = fs::path(CCFR_SOURCE_DIR) / "configs";
  int n = 0;
  for (const auto& entry : fs::directory_iterator(configs)) {
    if (entry.path().extension() != ".yaml") continue;
    SCOPED_TRACE(entry.path().string());
    const auto s = io::load_scene(entry.path());
    EXPECT_GT(s.scene.topo.num_vertices(), 0);
    ++n;
  }
  EXPECT_GT(n, 0);
}

TEST(SceneLoader, DocsConfigReferenceIsGeneratedFromTheSchema) {
  const fs::path doc = fs::path(CCFR_SOURCE_DIR) / "docs" / "config.md";
  std::ifstream in(doc);
  ASSERT_TRUE(in) << doc;
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_NE(text.find(io::config_reference_markdown()), std::string::npos)
      << "docs/config.md is stale: regenerate the table with `ccfr schema` (see docs/config.md)";
}

TEST(Obj, FrameRoundTripKeepsObjectsAndIndices) {
  TopologyBuilder b;
  b.add_object("quad", ObjectKind::cloth, 4, {{0, 1, 2}, {0, 2, 3}});
  b.add_object("hair", ObjectKind::strand, 3, {}, {}, {{0, 1, 2}});
  b.add_object("dust", ObjectKind::particles, 2);
  const Topology t = b.finish();
  Positions x;
  for (int i = 0; i < 9; ++i) x.emplace_back(0.1 * i, 1.0 / 3.0 * i, -1e-17 * i);
  const fs::path p = fs::temp_directory_path() / "ccfr_roundtrip.obj";
  io::write_frame_obj(p, t, x);
  const auto fr = io::read_frame_obj(p);
  ASSERT_EQ(fr.v.size(), 9u);
  for (int i = 0; i < 9; ++i) EXPECT_EQ(fr.v[i], x[i]);  // %.17g round-trips exactly
  ASSERT_EQ(fr.objects.size(), 3u);
  EXPECT_EQ(fr.objects[1].name, "hair");
  EXPECT_EQ(fr.faces, t.faces);
  ASSERT_EQ(fr.lines.size(), 1u);
  EXPECT_EQ(fr.lines[0], (std::vector<Index>{4, 5, 6}));
  EXPECT_EQ(fr.points, (std::vector<Index>{7, 8}));
  for (const auto& e : fs::directory_iterator(p.parent_path()))
    EXPECT_EQ(e.path().string().find("ccfr_roundtrip.obj.tmp"), std::string::npos) << "temporary file left behind";
}

TEST(Obj, MalformedAndNonFiniteFramesNameFileAndLine) {
  const fs::path p = fs::temp_directory_path() / "ccfr_bad.obj";
  std::ofstream(p) << "o a\nv 0 0 0\nv nan 0 0\n";
  try {
    io::read_frame_obj(p);
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("ccfr_bad.obj:3"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("non-finite"), std::string::npos);
  }
  std::ofstream(p) << "v 0 0 0\nf 1 2 3\n";
  EXPECT_THROW(io::read_frame_obj(p), Error);
  EXPECT_THROW(io::read_frame_obj(fs::temp_directory_path() / "ccfr_no_such.obj"), Error);
}

// Solver-specific keys live in the solver's own section, read from the registry.
TEST(SceneLoader, SolverSectionsReachTheSolverAndAreRefusedForAnotherSolver) {
  std::string y = kBase;
  y.replace(y.find("  radius: 0.01\n"), 15, "  radius: 0.01\n  solver: toi_clamp\n  toi_clamp: {scale: 0.5}\n");
  const auto s = io::load_scene_text(y, "scene.yaml", ".");
  EXPECT_EQ(s.scene.params.contact.solver, "toi_clamp");
  EXPECT_DOUBLE_EQ(s.scene.params.contact.solver_params.number("scale"), 0.5);
  EXPECT_EQ(s.scene.params.contact.solver_params.integer("max_iterations"), 1000);  // the registered default
  EXPECT_NE(s.resolved_json.find("\"scale\": 0.5"), std::string::npos) << s.resolved_json;

  // The same section under another solver: the section, its line and the selecting key.
  std::string other = y;
  other.replace(other.find("solver: toi_clamp"), 17, "solver: ccfr");
  const auto e = config_error(other);
  EXPECT_EQ(e.key_path(), "contact.toi_clamp");
  EXPECT_EQ(e.line(), 8);
  EXPECT_NE(e.detail().find("contact.solver is 'ccfr'"), std::string::npos) << e.what();
  // Out of range, from the registered spec.
  const auto r = config_error(y, {"contact.toi_clamp.scale=0"});
  EXPECT_EQ(r.key_path(), "contact.toi_clamp.scale");
  // Unknown key inside a section lists the solver's keys.
  std::string unknown = y;
  unknown.replace(unknown.find("{scale: 0.5}"), 12, "{scael: 0.5}");
  const auto u = config_error(unknown);
  EXPECT_EQ(u.key_path(), "contact.toi_clamp.scael");
  EXPECT_NE(u.detail().find("scale"), std::string::npos) << u.what();
}

// ogc and dat: their registered sections, γ_p's open range (two sides at 1/2 each would meet at
// the offset with no margin) and the file line of a bad value.
TEST(SceneLoader, TrustRegionSolverSectionsAreCheckedFromTheRegistry) {
  for (const std::string solver : {"ogc", "dat"}) {
    std::string y = kBase;
    y.replace(y.find("  radius: 0.01\n"), 15,
              "  radius: 0.01\n  solver: " + solver + "\n  " + solver + ": {gamma_p: 0.3, gamma_e: 0.05}\n");
    const auto s = io::load_scene_text(y, "scene.yaml", ".");
    EXPECT_DOUBLE_EQ(s.scene.params.contact.solver_params.number("gamma_p"), 0.3);
    EXPECT_DOUBLE_EQ(s.scene.params.contact.solver_params.number("query_radius"), 0.0);  // the default
    const auto e = config_error(y, {"contact." + solver + ".gamma_p=0.5"});
    EXPECT_EQ(e.key_path(), "contact." + solver + ".gamma_p");
    EXPECT_NE(e.detail().find("(0, 0.5)"), std::string::npos) << e.what();
  }
}

TEST(SceneLoader, MovedKeysNameTheirNewPlace) {
  std::string y = kBase;
  y.replace(y.find("  radius: 0.01\n"), 15, "  radius: 0.01\n  projection_sweeps: 8\n");
  const auto e = config_error(y);
  EXPECT_EQ(e.key_path(), "contact.projection_sweeps");
  EXPECT_EQ(e.line(), 7);
  EXPECT_NE(e.detail().find("contact.successive_projection.sweeps"), std::string::npos) << e.what();
}
