// Output formats for other programs (docs/interop.md), checked with the real programs: Debian's
// Blender (Mesh Cache modifier on the PC2 caches, run headless) and VTK's own XML reader
// (python3-vtk9), against the exact OBJ frames of the same run.
#include <gtest/gtest.h>
#include <unistd.h>

#include <Eigen/Geometry>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <regex>
#include <sstream>
#include <string>

#include "ccfr/io/formats.hpp"
#include "ccfr/io/obj.hpp"
#include "ccfr/render/image.hpp"
#include "cli_support.hpp"

namespace fs = std::filesystem;
using ccfr::Vec3;
using nlohmann::json;

namespace {

// A cloth above a sphere (contact from frame 1 on), a tet block falling freely far from both
// (its velocity is g t exactly), and an object name with a space.
const char* kScene = R"(scene: interop
time: {fps: 30, frames: 6, substeps: 5, iterations: 2, xpbd_sweeps: 4}
contact: {solver: ccfr, offset: 0.01}
output: {formats: [obj, ply, vtu, pc2, usda]}
objects:
  - name: cloth sheet
    kind: cloth
    shape: {type: grid, size: [0.6, 0.6], resolution: [12, 12]}
    transform: {translate: [0, 0.24, 0]}
  - name: block
    kind: tet_solid
    shape: {type: tet_box, size: [0.2, 0.1, 0.2], resolution: [2, 1, 2]}
    transform: {translate: [1.5, 0.3, 0]}
  - name: ball
    kind: obstacle
    shape: {type: sphere, radius: 0.2, subdivisions: 2}
)";

constexpr double kFps = 30.0;
constexpr int kFrames = 6;

bool has_program(const std::string& p) { return std::system(("command -v " + p + " >/dev/null 2>&1").c_str()) == 0; }

/// Output of a shell command, stdout and stderr.
std::string shell(const std::string& cmd, int* code = nullptr) {
  std::string out;
  FILE* p = popen((cmd + " 2>&1").c_str(), "r");
  if (!p) return out;
  char buf[4096];
  while (size_t n = fread(buf, 1, sizeof buf, p)) out.append(buf, n);
  const int st = pclose(p);
  if (code) *code = WIFEXITED(st) ? WEXITSTATUS(st) : -1;
  return out;
}

/// The JSON after "RESULT " in a script's output.
json result_of(const std::string& out) {
  const auto at = out.find("RESULT ");
  if (at == std::string::npos) return json();
  return json::parse(out.substr(at + 7, out.find('\n', at) - at - 7), nullptr, false);
}

class Interop : public ::testing::Test {
 protected:
  // ctest runs each test in its own process, in parallel: one directory per process.
  static std::string scratch_name() { return "interop-" + std::to_string(::getpid()); }
  static fs::path run_dir() { return ccfr::test::scratch_path(scratch_name()) / "run"; }
  static void SetUpTestSuite() {
    const fs::path d = ccfr::test::scratch_dir(scratch_name());
    std::ofstream(d / "scene.yaml") << kScene;
    const auto r = ccfr::test::run_ccfr("run " + (d / "scene.yaml").string() + " --out " + run_dir().string());
    ASSERT_EQ(r.code, 0) << r.out;
  }
  static ccfr::io::Frame obj(int f) {
    char name[32];
    std::snprintf(name, sizeof name, "frame_%05d.obj", f);
    return ccfr::io::read_frame_obj(run_dir() / "frames" / name);
  }
};

TEST_F(Interop, PlyFramesHoldTheObjPositionsAsFloats) {
  for (int f = 0; f <= kFrames; ++f) {
    char name[32];
    std::snprintf(name, sizeof name, "frame_%05d.ply", f);
    const auto ply = ccfr::io::read_ply_positions(run_dir() / "frames" / name);
    const auto ref = obj(f);
    ASSERT_EQ(ply.size(), ref.v.size());
    for (size_t v = 0; v < ply.size(); ++v)
      for (int k = 0; k < 3; ++k) EXPECT_EQ(ply[v][k], double(float(ref.v[v][k]))) << f << " " << v;
  }
}

TEST_F(Interop, Pc2CachesHoldEveryFrameOfTheirObject) {
  const json m = json::parse(std::ifstream(run_dir() / "blender" / "manifest.json"));
  ASSERT_EQ(m["objects"].size(), 3u);
  EXPECT_EQ(m["objects"][0]["pc2"], "000_cloth_sheet.pc2");
  for (const auto& o : m["objects"]) {
    std::ifstream in(run_dir() / "blender" / o["pc2"].get<std::string>(), std::ios::binary);
    char sig[12];
    std::int32_t version, points, samples;
    float start, rate;
    in.read(sig, 12).read(reinterpret_cast<char*>(&version), 4).read(reinterpret_cast<char*>(&points), 4);
    in.read(reinterpret_cast<char*>(&start), 4).read(reinterpret_cast<char*>(&rate), 4);
    in.read(reinterpret_cast<char*>(&samples), 4);
    EXPECT_EQ(std::string(sig, 11), "POINTCACHE2");
    EXPECT_EQ(version, 1);
    const int b = o["vertex_begin"], e = o["vertex_end"];
    EXPECT_EQ(points, e - b);
    EXPECT_EQ(start, 0.0f);
    EXPECT_EQ(rate, 1.0f);
    ASSERT_EQ(samples, kFrames + 1);
    for (int f = 0; f < samples; ++f) {
      const auto ref = obj(f);
      for (int v = b; v < e; ++v) {
        float c[3];
        ASSERT_TRUE(in.read(reinterpret_cast<char*>(c), sizeof c));
        for (int k = 0; k < 3; ++k) ASSERT_EQ(c[k], float(ref.v[v][k]));
      }
    }
    EXPECT_EQ(in.peek(), EOF) << "no bytes after the counted samples";
  }
}

// The USDA file's structure, read back with a parser written here (Debian packages no USD library,
// and its Blender 3.4.1 is built without USD: bpy.app.build_options.usd is False); the values are
// also read by TinyUSDZ below.
TEST_F(Interop, UsdaHoldsTopologyOnceAndPointsPerTimeCode) {
  const std::string s = ccfr::test::read_text(run_dir() / "usd" / "scene.usda");
  ASSERT_EQ(s.rfind("#usda 1.0", 0), 0u);
  EXPECT_NE(s.find("timeCodesPerSecond = 30"), std::string::npos);
  EXPECT_NE(s.find("endTimeCode = 6"), std::string::npos);
  // Prims: one per object, the space of "cloth sheet" replaced.
  EXPECT_NE(s.find("def Mesh \"cloth_sheet\""), std::string::npos);
  EXPECT_NE(s.find("def Mesh \"block\""), std::string::npos);
  EXPECT_NE(s.find("def Mesh \"ball\""), std::string::npos);
  size_t topo = 0;
  for (size_t at = s.find("faceVertexIndices"); at != std::string::npos; at = s.find("faceVertexIndices", at + 1))
    ++topo;
  EXPECT_EQ(topo, 3u) << "topology written once per prim";
  // The cloth's samples: "N: [(x, y, z), ...]" for N = 0..6, against the OBJ frames.
  const size_t cloth = s.find("def Mesh \"cloth_sheet\""), samples = s.find("points.timeSamples", cloth);
  ASSERT_NE(samples, std::string::npos);
  const std::regex point(R"(\(([-0-9.e+]+), ([-0-9.e+]+), ([-0-9.e+]+)\))");
  for (int f = 0; f <= kFrames; ++f) {
    const std::string key = "\n            " + std::to_string(f) + ": [";
    const size_t at = s.find(key, samples);
    ASSERT_NE(at, std::string::npos) << "time code " << f;
    const std::string list = s.substr(at + key.size(), s.find(']', at) - at - key.size());
    const auto ref = obj(f);
    size_t v = 0;
    for (auto it = std::sregex_iterator(list.begin(), list.end(), point); it != std::sregex_iterator(); ++it, ++v)
      for (int k = 0; k < 3; ++k) ASSERT_NEAR(std::stod((*it)[k + 1]), ref.v[v][k], 1e-7) << f << " " << v;
    EXPECT_EQ(v, 169u) << "13 x 13 cloth vertices";
  }
}

// The same layer read by a USD reader that is not ccfr's: TinyUSDZ (npm `tinyusdz`, WebAssembly,
// tests/interop/node_modules from scripts/install-deps) through node (docs/interop.md, USD).
TEST_F(Interop, TinyUsdzReadsEveryTimeSampleAsWritten) {
  const fs::path modules = fs::path(CCFR_SOURCE_DIR) / "tests" / "interop" / "node_modules";
  if (!has_program("node") || !has_program("timeout") || !fs::exists(modules / "tinyusdz" / "tinyusdz.wasm"))
    GTEST_SKIP() << "node, timeout or tests/interop/node_modules/tinyusdz missing (scripts/install-deps installs them)";
  // node is bounded: one CI run saw it hang for the test's whole 600 s (30 runs here took 0.6 s
  // each, under ASan too); a check that runs out (exit 124) is run once more.
  const std::string check = "timeout -k 10 120 node " + std::string(CCFR_SOURCE_DIR) + "/tests/interop/check_usda.mjs ";
  int code = -1;
  std::string out = shell(check + run_dir().string() + " " + modules.string(), &code);
  if (code == 124) out = shell(check + run_dir().string() + " " + modules.string(), &code);
  ASSERT_EQ(code, 0) << out;
  json r = result_of(out);
  ASSERT_TRUE(r.is_object()) << out;
  EXPECT_EQ(r["prims"], 3);
  EXPECT_EQ(r["meshes"], 3);
  EXPECT_EQ(r["time_codes"], kFrames + 1);
  EXPECT_EQ(r["samples"], 3 * (kFrames + 1));
  EXPECT_LT(r["max_error"].get<double>(), 1e-6);  // float32 of the OBJ's doubles
  EXPECT_LT(r["render_scene_error"].get<double>(), 1e-6);

  // The reader must see a wrong sample: a copy with one coordinate of time code 3 moved by 1e-4 m.
  const fs::path bad = ccfr::test::scratch_dir(scratch_name() + "-usd");
  fs::create_directories(bad / "usd");
  fs::create_directory_symlink(run_dir() / "frames", bad / "frames");
  std::string s = ccfr::test::read_text(run_dir() / "usd" / "scene.usda");
  const std::string key = "\n            3: [(";
  const auto at = s.find(key);
  ASSERT_NE(at, std::string::npos);
  const auto b = at + key.size(), e = s.find(',', b);
  s.replace(b, e - b, std::to_string(std::stod(s.substr(b, e - b)) + 1e-4));
  std::ofstream(bad / "usd" / "scene.usda") << s;
  out = shell(check + bad.string() + " " + modules.string(), &code);
  if (code == 124) out = shell(check + bad.string() + " " + modules.string(), &code);
  EXPECT_EQ(code, 1) << out;
  EXPECT_NE(out.find("FAIL points differ from the OBJ frames"), std::string::npos) << out;
  r = result_of(out);
  ASSERT_TRUE(r.is_object()) << out;
  EXPECT_NEAR(r["max_error"].get<double>(), 1e-4, 1e-6);
}

TEST_F(Interop, VtkReaderReadsEveryFieldAsWritten) {
  if (!fs::exists("/usr/bin/python3") || shell("/usr/bin/python3 -c 'import vtk'").find("Error") != std::string::npos)
    GTEST_SKIP() << "python3-vtk9 is not installed (scripts/install-deps)";
  int code = -1;
  const std::string out = shell(
      "/usr/bin/python3 " + std::string(CCFR_SOURCE_DIR) + "/tests/interop/check_vtk.py " + run_dir().string(), &code);
  ASSERT_EQ(code, 0) << out;
  const json r = result_of(out);
  ASSERT_TRUE(r.is_object()) << out;
  ASSERT_EQ(r["frames"].size(), size_t(kFrames + 1));
  bool contact = false;
  for (const auto& f : r["frames"]) {
    const int frame = f["frame"];
    SCOPED_TRACE("frame " + std::to_string(frame));
    EXPECT_EQ(f["points"], f["obj_vertices"]);
    EXPECT_EQ(f["cells"], 288 + 24 + 320);  // cloth triangles, block tets, ball triangles
    EXPECT_EQ(f["fields"], json({"distance", "half_spaces", "halted", "object_id", "velocity"}));
    EXPECT_LT(f["time_error"].get<double>(), 1e-12);
    EXPECT_LT(f["max_position_error"].get<double>(), 1e-6);  // float32 of coordinates below 2 m
    EXPECT_EQ(f["object_id_mismatches"], 0);
    EXPECT_EQ(f["velocity_components"], 3);
    // The block falls freely: v = g t exactly, up to float32.
    const json& block = f["velocity_by_object"]["1"];
    EXPECT_NEAR(block[0].get<double>(), -9.81 * frame / kFps, 1e-5);
    EXPECT_NEAR(block[1].get<double>(), -9.81 * frame / kFps, 1e-5);
    EXPECT_LT(block[2].get<double>(), 1e-6);
    // Halting flags mark distinct vertices; stats.csv sums halting events over the passes.
    EXPECT_LE(f["halted_flagged"].get<int>(), f["halted_events"].get<int>());
    EXPECT_EQ(f["halted_flagged"].get<int>() > 0, f["halted_events"].get<int>() > 0);
    EXPECT_LE(f["max_half_spaces"].get<int>(), std::max(1, f["max_constraints"].get<int>()));
    if (!f["stats_min_distance"].is_null()) {
      contact = true;
      ASSERT_FALSE(f["min_distance"].is_null());
      // The field is the last detection's; stats.csv has the smallest over every detection of
      // the frame (within float32 rounding).
      EXPECT_GE(f["min_distance"].get<double>(), f["stats_min_distance"].get<double>() * (1 - 1e-6));
      EXPECT_GT(f["vertices_with_half_spaces"].get<int>(), 0);
    }
  }
  EXPECT_TRUE(contact) << "the scene must produce contact for the diagnostics to be checked";
}

TEST_F(Interop, BlenderPlaysThePointCachesAsWritten) {
  if (!has_program("blender")) GTEST_SKIP() << "blender is not installed (scripts/install-deps)";
  int code = -1;
  const std::string out = shell("blender -b --factory-startup --python " + std::string(CCFR_SOURCE_DIR) +
                                    "/tests/interop/check_blender.py -- " + run_dir().string() + " pc2 0 3 6",
                                &code);
  ASSERT_EQ(code, 0) << out;
  const json r = result_of(out);
  ASSERT_TRUE(r.is_object()) << out;
  EXPECT_EQ(r["objects"], 3);
  ASSERT_EQ(r["frames"].size(), 3u);
  for (const auto& f : r["frames"]) {
    EXPECT_EQ(f["compared"], obj(0).v.size()) << f.dump();
    EXPECT_TRUE(f["missing"].empty()) << f.dump();
    EXPECT_LT(f["max_error"].get<double>(), 1e-6) << f.dump();  // float32 of coordinates below 2 m
  }
  // The comparison means something only if the frames differ by far more than that.
  double moved = 0;
  const auto a = obj(0), b = obj(6);
  for (size_t v = 0; v < a.v.size(); ++v) moved = std::max(moved, (a.v[v] - b.v[v]).norm());
  EXPECT_GT(moved, 0.1);
}

// The import as docs/interop.md gives it (headless, no --factory-startup): the startup file's cube,
// light and camera are removed, the .blend it saves reopens with the run's objects, timeline and
// point caches (referenced relative to the .blend).
TEST_F(Interop, BlenderImportAsDocumentedSavesACleanBlend) {
  if (!has_program("blender")) GTEST_SKIP() << "blender is not installed (scripts/install-deps)";
  const fs::path d = ccfr::test::scratch_dir(scratch_name() + "-blend");
  const std::string src = CCFR_SOURCE_DIR;
  int code = -1;
  std::string out = shell("cd " + d.string() + " && blender -b --python " + src + "/scripts/import_blender.py -- " +
                              run_dir().string() + " --z-up --save out/run.blend",
                          &code);
  ASSERT_EQ(code, 0) << out;
  EXPECT_NE(out.find("import_blender: 3 objects (cloth sheet, block, ball), frames 0-6 at 30 fps"), std::string::npos)
      << out;
  // A correct import prints no modifier error (it printed "No such file or directory" twice when
  // the caches' '//' paths were set before the .blend had a path).
  EXPECT_EQ(out.find("ERROR"), std::string::npos) << out;
  ASSERT_TRUE(fs::exists(d / "out" / "run.blend")) << out;

  out = shell("blender -b " + (d / "out" / "run.blend").string() + " --python " + src +
                  "/tests/interop/check_blender.py -- " + run_dir().string() + " blend 0 3 6",
              &code);
  ASSERT_EQ(code, 0) << out;
  const json r = result_of(out);
  ASSERT_TRUE(r.is_object()) << out;
  EXPECT_EQ(r["all_objects"], json::array({json::array({"ball", "MESH"}), json::array({"block", "MESH"}),
                                           json::array({"cloth sheet", "MESH"})}));
  const json run = json::parse(std::ifstream(run_dir() / "run.json"));
  const int every = run["config"]["output"]["every"];
  EXPECT_EQ(r["frame_start"], 0);
  EXPECT_EQ(r["frame_end"].get<int>(), (run["frames_written"].get<int>() - 1) * every);
  EXPECT_EQ(r["frame_end"], kFrames);
  EXPECT_DOUBLE_EQ(r["fps"].get<double>(), run["fps"].get<double>());
  ASSERT_EQ(r["frames"].size(), 3u);
  for (const auto& f : r["frames"]) {
    EXPECT_EQ(f["compared"], obj(0).v.size()) << f.dump();
    EXPECT_TRUE(f["missing"].empty()) << f.dump();
    // Float32 rounding of coordinates below 2 m is at most 2^-24 * 2 m = 1.2e-7 m.
    EXPECT_LE(f["max_error"].get<double>(), 1.2e-7) << f.dump();
  }

  out = shell("blender -b --python " + src + "/scripts/import_blender.py -- " + (d / "nothing").string(), &code);
  EXPECT_EQ(code, 1) << out;
  EXPECT_NE(
      out.find("import_blender: error: " + (d / "nothing" / "blender" / "manifest.json").string() + " does not exist"),
      std::string::npos)
      << out;
}

// scripts/paraview_open.py under pvbatch, headless as docs/interop.md gives it: ParaView's PVD reader
// sees every frame and vertex, and the screenshot shows something.
TEST_F(Interop, ParaViewOpensThePvdAndSavesAScreenshot) {
  if (!has_program("pvbatch")) GTEST_SKIP() << "pvbatch is not installed (package paraview, scripts/install-deps)";
  // python3-paraview holds pvbatch's Python modules (and conflicts with python3-vtk9).
  if (shell("/usr/bin/python3 -c 'import paraview'").find("Error") != std::string::npos)
    GTEST_SKIP() << "python3-paraview is not installed (scripts/install-deps)";
  const fs::path d = ccfr::test::scratch_dir(scratch_name() + "-paraview");
  const std::string script = std::string(CCFR_SOURCE_DIR) + "/scripts/paraview_open.py ";
  int code = -1;
  std::string out = shell("xvfb-run -a -s '-screen 0 1280x1024x24 -noreset' pvbatch --no-mpi " + script +
                              run_dir().string() + " --frame 3 --halted --size 480 360 --screenshot " +
                              (d / "pv.png").string() + " --state " + (d / "pv.pvsm").string(),
                          &code);
  ASSERT_EQ(code, 0) << out;
  std::smatch m;
  ASSERT_TRUE(std::regex_search(
      out, m,
      std::regex(R"(paraview_open: \S+: (\d+) time steps \(times 0-0\.2\), frame 3 at time 0\.1: (\d+) points, )"
                 R"((\d+) cells; distance in \[(\S+), (\S+)\]; (\d+) halted vertices shown)")))
      << out;
  EXPECT_EQ(std::stoi(m[1]), kFrames + 1);
  EXPECT_EQ(size_t(std::stoi(m[2])), obj(3).v.size());
  EXPECT_EQ(std::stoi(m[3]), 288 + 24 + 320);  // cloth triangles, block tets, ball triangles
  // The cloth lies on the ball at frame 3: contact distances exist, and no penetration.
  EXPECT_GT(std::stod(m[4]), 0.0);
  EXPECT_LE(std::stod(m[4]), std::stod(m[5]));
  EXPECT_LE(size_t(std::stoi(m[6])), obj(3).v.size());
  EXPECT_TRUE(fs::exists(d / "pv.pvsm"));

  const auto img = ccfr::render::read_png(d / "pv.png");
  ASSERT_EQ(img.width, 480);
  ASSERT_EQ(img.height, 360);
  double sum = 0, sum2 = 0;
  for (size_t i = 0; i < img.rgb.size(); ++i) sum += img.rgb[i], sum2 += double(img.rgb[i]) * img.rgb[i];
  const double n = double(img.rgb.size()), variance = sum2 / n - (sum / n) * (sum / n);
  EXPECT_GT(variance, 100.0) << "a blank (or nearly one-colour) screenshot";

  // --halted shows exactly the flagged vertices (not every corner of their cells): frame 3 with
  // vertices 0, 5 and 200 flagged, rewritten by VTK's writer, as a one-frame run.
  fs::create_directories(d / "flagged" / "vtk");
  std::ofstream(d / "flag.py") << "import sys, vtk\n"
                                  "r = vtk.vtkXMLUnstructuredGridReader()\n"
                                  "r.SetFileName(sys.argv[1]); r.Update()\n"
                                  "g = r.GetOutput(); h = g.GetPointData().GetArray('halted')\n"
                                  "for i in range(h.GetNumberOfTuples()): h.SetValue(i, int(i in (0, 5, 200)))\n"
                                  "w = vtk.vtkXMLUnstructuredGridWriter()\n"
                                  "w.SetFileName(sys.argv[2]); w.SetInputData(g); w.Write()\n";
  out = shell("/usr/bin/python3 " + (d / "flag.py").string() + " " + (run_dir() / "vtk" / "frame_00003.vtu").string() +
                  " " + (d / "flagged" / "vtk" / "frame_00003.vtu").string(),
              &code);
  ASSERT_EQ(code, 0) << out;
  std::ofstream(d / "flagged" / "vtk" / "frames.pvd")
      << "<?xml version=\"1.0\"?>\n<VTKFile type=\"Collection\" version=\"0.1\">\n<Collection>\n"
         "<DataSet timestep=\"0.1\" file=\"frame_00003.vtu\"/>\n</Collection>\n</VTKFile>\n";
  out = shell("xvfb-run -a -s '-screen 0 1280x1024x24 -noreset' pvbatch --no-mpi " + script + (d / "flagged").string() +
                  " --halted --size 320 240 --screenshot " + (d / "flagged.png").string(),
              &code);
  ASSERT_EQ(code, 0) << out;
  EXPECT_NE(out.find(": 1 time steps (times 0.1-0.1), frame 3 at time 0.1: "), std::string::npos) << out;
  EXPECT_NE(out.find("; 3 halted vertices shown"), std::string::npos) << out;

  out = shell("pvbatch --no-mpi " + script + (d / "nothing").string(), &code);
  EXPECT_NE(code, 0) << out;
  EXPECT_NE(out.find("paraview_open: " + (d / "nothing" / "vtk" / "frames.pvd").string() + " does not exist"),
            std::string::npos)
      << out;
}

// docs/interop.md's VTK-only snippet (no ParaView), run as printed, from a directory holding the run
// as runs/body.
TEST_F(Interop, VtkOnlySnippetInTheDocsReadsEveryFrame) {
  if (!fs::exists("/usr/bin/python3") || shell("/usr/bin/python3 -c 'import vtk'").find("Error") != std::string::npos)
    GTEST_SKIP() << "python3-vtk9 is not installed (scripts/install-deps)";
  const std::string doc = ccfr::test::read_text(fs::path(CCFR_SOURCE_DIR) / "docs" / "interop.md");
  const std::string head = "```python\n# Every frame of a run with VTK alone";
  const auto begin = doc.find(head);
  ASSERT_NE(begin, std::string::npos) << "docs/interop.md lost its VTK snippet";
  const auto end = doc.find("```\n", begin + head.size());
  ASSERT_NE(end, std::string::npos);
  const fs::path d = ccfr::test::scratch_dir(scratch_name() + "-snippet");
  std::ofstream(d / "snippet.py") << doc.substr(begin + 10, end - begin - 10);
  fs::create_directories(d / "runs");
  fs::remove(d / "runs" / "body");
  fs::create_directory_symlink(run_dir(), d / "runs" / "body");
  int code = -1;
  const std::string out = shell("cd " + d.string() + " && /usr/bin/python3 snippet.py", &code);
  ASSERT_EQ(code, 0) << out;
  std::istringstream lines(out);
  std::string line;
  int frame = 0, contact = 0;
  while (std::getline(lines, line)) {
    std::istringstream in(line);
    double time = -1, x = 0, y = 0, z = 0;
    size_t points = 0, cells = 0, halted = 0;
    std::string dist;
    if (!(in >> time >> points >> cells >> halted >> dist >> x >> y >> z)) continue;  // VTK's warnings
    SCOPED_TRACE("frame " + std::to_string(frame) + ": " + line);
    const auto ref = obj(frame);
    EXPECT_NEAR(time, frame / kFps, 1e-9);
    EXPECT_EQ(points, ref.v.size());
    EXPECT_EQ(cells, 288u + 24u + 320u);
    EXPECT_LE(halted, points);
    // NaN: no contact pair within range; else never a penetration.
    if (dist != "nan") EXPECT_GT(std::stod(dist), 0.0) << dist;
    contact += dist != "nan";
    EXPECT_NEAR(x, ref.v[0].x(), 1e-6);
    EXPECT_NEAR(y, ref.v[0].y(), 1e-6);
    EXPECT_NEAR(z, ref.v[0].z(), 1e-6);
    ++frame;
  }
  EXPECT_EQ(frame, kFrames + 1) << out;
  EXPECT_GT(contact, 0) << "the run must have contact for the distances to be checked\n" << out;
}

TEST_F(Interop, ExportFromDiskMatchesTheLiveWriters) {
  const fs::path out = ccfr::test::scratch_path(scratch_name()) / "exported";
  fs::remove_all(out);
  const auto r =
      ccfr::test::run_ccfr("export " + run_dir().string() + " --format ply,pc2,usda,vtu --out " + out.string());
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("exported 7 frames"), std::string::npos) << r.out;
  // The summary ends with the time taken and the command that shows the first format exported
  // that has a viewer (pc2: Blender with the importer).
  EXPECT_NE(r.out.find("into " + out.string() + " in "), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("import_blender.py -- " + out.string() + "\n"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("; next: blender --python "), std::string::npos) << r.out;
  const auto bytes = [](const fs::path& p) { return ccfr::test::read_text(p); };
  for (const char* f : {"frames/frame_00004.ply", "blender/000_cloth_sheet.pc2", "blender/002_ball.pc2"})
    EXPECT_EQ(bytes(out / f), bytes(run_dir() / f)) << f;
  EXPECT_TRUE(fs::exists(out / "vtk" / "frames.pvd"));
  EXPECT_TRUE(fs::exists(out / "usd" / "scene.usda"));
}

TEST_F(Interop, UnknownFormatsAreRefused) {
  auto r = ccfr::test::run_ccfr("export " + run_dir().string() + " --format gltf");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("unknown output format 'gltf' (supported: obj, pc2, ply, usda, vtu)"), std::string::npos)
      << r.out;
  const fs::path d = ccfr::test::scratch_dir("interop_bad");
  std::ofstream(d / "s.yaml") << "objects: [{name: a, kind: cloth, shape: {type: grid, size: [1, 1], resolution: [1, "
                                 "1]}}]\noutput:\n  formats: [obj, gltf]\n";
  r = ccfr::test::run_ccfr("run " + (d / "s.yaml").string() + " --out " + (d / "o").string());
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("output.formats[1]"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("s.yaml:3:"), std::string::npos) << r.out;
}

// An obstacle animated by an OBJ sequence follows the linear interpolation of its keys, and the
// automatic subdivision splits substeps whose scripted step exceeds r.
TEST(InteropInput, ObjSequenceAnimatesAnObstacleWithinTheStepBound) {
  const fs::path d = ccfr::test::scratch_dir("interop_sequence");
  const Vec3 offsets[] = {Vec3(0, 0, 0), Vec3(0.3, 0, 0), Vec3(0.3, 0.3, 0)};
  const char* cube = "v 0 0 0\nv 0.1 0 0\nv 0.1 0.1 0\nv 0 0.1 0\nv 0 0 0.1\nv 0.1 0 0.1\nv 0.1 0.1 0.1\nv 0 0.1 0.1\n";
  const std::string faces =
      "f 1 3 2\nf 1 4 3\nf 5 6 7\nf 5 7 8\nf 1 2 6\nf 1 6 5\nf 2 3 7\nf 2 7 6\nf 3 4 8\nf 3 8 7\nf 4 1 5\nf 4 5 8\n";
  for (int k = 0; k < 3; ++k) {
    std::ofstream o(d / ("key_" + std::to_string(k) + ".obj"));
    std::istringstream in(cube);
    for (std::string v; std::getline(in, v);) {
      double x, y, z;
      std::sscanf(v.c_str(), "v %lf %lf %lf", &x, &y, &z);
      o << "v " << x + offsets[k].x() << " " << y + offsets[k].y() << " " << z + offsets[k].z() << "\n";
    }
    o << faces;
  }
  std::ofstream(d / "s.yaml") << R"(time: {fps: 20, frames: 6, substeps: 2}
contact: {radius: 0.005}
objects:
  - name: mover
    kind: obstacle
    shape: {type: mesh, path: key_0.obj}
    animation: {path: key_%d.obj, count: 3, fps: 10}
)";
  const auto r = ccfr::test::run_ccfr("run " + (d / "s.yaml").string() + " --out " + (d / "run").string());
  ASSERT_EQ(r.code, 0) << r.out;
  const auto rest = ccfr::io::read_frame_obj(d / "key_0.obj");
  for (int f = 0; f <= 6; ++f) {
    char name[32];
    std::snprintf(name, sizeof name, "frame_%05d.obj", f);
    const auto fr = ccfr::io::read_frame_obj(d / "run" / "frames" / name);
    const double key = std::min(2.0, f / 20.0 * 10.0);  // the key index at t = f / 20
    const int k0 = std::min(1, int(key));
    const Vec3 off = offsets[k0] + (key - k0) * (offsets[k0 + 1] - offsets[k0]);
    for (size_t v = 0; v < fr.v.size(); ++v) EXPECT_LT((fr.v[v] - (rest.v[v] + off)).norm(), 1e-12) << f << " " << v;
  }
  // 0.3 m per 0.1 s is 0.075 m per substep of 1/40 s: 17 pieces of at most 0.9 r = 4.5 mm each.
  const auto substeps_run = ccfr::test::csv_column(d / "run" / "stats.csv", "substeps_run");
  ASSERT_GE(substeps_run.size(), 2u);
  EXPECT_EQ(ccfr::test::csv_column(d / "run" / "stats.csv", "frame")[0], "1");
  EXPECT_EQ(substeps_run[0], "34");  // frame 1: 2 substeps of 17 pieces

  // Bad sequences: a file with another vertex count, a pattern without a number.
  std::ofstream(d / "key_9.obj") << "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
  std::ofstream(d / "bad.yaml") << R"(objects:
  - name: mover
    kind: obstacle
    shape: {type: mesh, path: key_0.obj}
    animation: {path: key_%d.obj, first: 9, count: 2}
)";
  auto e = ccfr::test::run_ccfr("run " + (d / "bad.yaml").string() + " --out " + (d / "bad").string());
  EXPECT_EQ(e.code, 2) << e.out;
  EXPECT_NE(e.out.find("key_9.obj' has 3 vertices, the object 8"), std::string::npos) << e.out;
  EXPECT_NE(e.out.find("bad.yaml:5: 'objects[0].animation.path': '"), std::string::npos) << e.out;
  std::ofstream(d / "bad.yaml") << R"(objects:
  - name: mover
    kind: obstacle
    shape: {type: mesh, path: key_0.obj}
    animation: {path: key_%s.obj, count: 2}
)";
  e = ccfr::test::run_ccfr("run " + (d / "bad.yaml").string() + " --out " + (d / "bad").string());
  EXPECT_EQ(e.code, 2) << e.out;
  EXPECT_NE(e.out.find("key_%s.obj' needs exactly one integer field"), std::string::npos) << e.out;
}

// Keyframed rigid transforms: slerp of the rotation, lerp of the translation, checked against
// the closed form (a rotation by a times the key angle) at every frame.
TEST(InteropInput, KeyframedObstacleFollowsSlerpAndLerp) {
  const fs::path d = ccfr::test::scratch_dir("interop_keyframes");
  std::ofstream(d / "s.yaml") << R"(time: {fps: 20, frames: 4}
objects:
  - name: box
    kind: obstacle
    shape: {type: box, size: [0.1, 0.1, 0.1]}
    keyframes:
      - {time: 0}
      - {time: 0.1, rotate_deg: 90, center: [0, 0, 0], translate: [0.2, 0, 0]}
)";
  // Every key names the same center (the default, the origin): the second key repeats it.
  const auto r = ccfr::test::run_ccfr("run " + (d / "s.yaml").string() + " --out " + (d / "run").string());
  ASSERT_EQ(r.code, 0) << r.out;
  const auto rest = ccfr::io::read_frame_obj(d / "run" / "frames" / "frame_00000.obj");
  for (int f = 1; f <= 4; ++f) {
    char name[32];
    std::snprintf(name, sizeof name, "frame_%05d.obj", f);
    const auto fr = ccfr::io::read_frame_obj(d / "run" / "frames" / name);
    const double a = std::min(1.0, f / 20.0 / 0.1);
    const Eigen::AngleAxisd rot(a * M_PI / 2, Vec3::UnitY());
    for (size_t v = 0; v < fr.v.size(); ++v)
      EXPECT_LT((fr.v[v] - (rot * rest.v[v] + a * Vec3(0.2, 0, 0))).norm(), 1e-12) << f << " " << v;
  }
  std::ofstream(d / "bad.yaml") << R"(objects:
  - name: box
    kind: obstacle
    shape: {type: box, size: [0.1, 0.1, 0.1]}
    keyframes: [{time: 0.2}, {time: 0.1}]
)";
  const auto e = ccfr::test::run_ccfr("run " + (d / "bad.yaml").string() + " --out " + (d / "bad").string());
  EXPECT_EQ(e.code, 2) << e.out;
  EXPECT_NE(e.out.find("'objects[0].keyframes[1].time': key times must increase"), std::string::npos) << e.out;
}

}  // namespace
