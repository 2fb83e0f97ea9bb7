// run.json, both sides (ccfr/io/run_json.hpp): what format_run_json() writes, parse_run_json()
// reads back equal; files written by an earlier ccfr (tests/data/run_json/, written by main at
// 5311d93 with `ccfr run configs/<scene>.yaml --set time.frames=1`) are read and rewritten byte
// for byte; files of older versions lacking keys are still read.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <string>

#include "ccfr/core/error.hpp"
#include "ccfr/io/output.hpp"
#include "ccfr/io/run_json.hpp"
#include "test_support.hpp"

namespace ccfr::io {
namespace {

namespace fs = std::filesystem;

std::string read_text(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

fs::path fixture(const std::string& name) { return fs::path(CCFR_SOURCE_DIR) / "tests/data/run_json" / name; }

/// The text of `config` in a run.json as written (`"config": {...}` is its last key).
std::string config_of(const std::string& text) {
  const std::string key = "\n  \"config\": ";
  const size_t a = text.find(key);
  const size_t b = text.rfind("\n}");
  EXPECT_NE(a, std::string::npos);
  return text.substr(a + key.size(), b - a - key.size());
}

/// `text` with its `"ccfr": {...}` object (version and commit of the build that wrote it) cut out.
std::string without_build(const std::string& text) {
  const size_t a = text.find("\"ccfr\": {");
  const size_t b = text.find('}', a);
  return text.substr(0, a) + text.substr(b + 1);
}

/// `text` without the keys run.json no longer writes: initial_proximity.adjacent_excluded (always
/// 0). Reading a file that has them still works.
std::string without_dropped_keys(std::string text) {
  const std::string line = "    \"adjacent_excluded\": 0,\n";
  if (const size_t a = text.find(line); a != std::string::npos) text.erase(a, line.size());
  return text;
}

TEST(RunJson, WhatIsWrittenIsReadBackEqual) {
  RunMeta m;
  m.scene = "stack";
  m.solver = "toi_clamp";
  m.broad_phase = "fcl";
  m.contact = {0.002, 0.004, 0.0003, 0.4, 0.25};
  m.fps = 48;
  m.threads = 3;
  m.command_line = "ccfr run 'my scene.yaml'";
  m.argv = {"ccfr", "run", "my scene.yaml"};
  InitialProximity ip;
  ip.adjacent_kept = 5;
  ip.intersecting_pairs = 2;
  ip.intersecting_excluded = 7;
  ip.reduced_offset = 11;
  ip.min_reduced_offset = 0.00123;
  ip.shortest_edge = 0.0375;
  m.initial_proximity = ip;
  m.formats = {"obj", "vtu", "usda"};
  m.every = 3;
  m.frames = true;
  m.scene_fingerprint = 0x00f1e2d3c4b5a697ULL;
  m.memory_estimate = 123456789.5;
  m.memory_limit = 8e9;
  RunProgress p;
  p.start_time = "2026-11-27T04:00:00Z";
  p.end_time = "2026-11-27T04:01:00Z";
  p.status = "failed: frame 3: 2 violations";
  p.frames_written = 4;
  p.resumed_json = R"([{"after_frame":2,"time":"2026-11-27T04:00:30Z"}])";
  p.stop_json = R"({"frame":3,"reason":"violations"})";
  p.vertices = 2323;
  p.peak_resident_bytes = 19013632;
  // Friction and the output settings travel inside the resolved scene.
  const std::string config = R"({"scene":"stack","contact":{"friction":{"static":0.4,"kinetic":0.25}},)"
                             R"("output":{"frames":true,"every":3,"formats":["obj","vtu","usda"]},)"
                             R"("objects":[{"name":"floor","kind":"obstacle"},{"name":"box","kind":"rigid",)"
                             R"("pins":[{"indices":[0]}]},{"name":"wave","kind":"obstacle","animation":"w.obj"},)"
                             R"({"name":"sheet","kind":"cloth"}]})";

  const std::string text = format_run_json(m, p, config);
  const RunInfo back = parse_run_json(text, "run.json");
  EXPECT_TRUE(back.has_run_json);
  EXPECT_TRUE(back.meta == m);
  EXPECT_EQ(back.meta.contact, m.contact);
  EXPECT_EQ(back.meta.initial_proximity, m.initial_proximity);
  EXPECT_EQ(back.meta.formats, m.formats);
  EXPECT_TRUE(back.progress == p) << back.progress.resumed_json << " " << back.progress.stop_json;
  EXPECT_EQ(back.obstacles, (std::vector<std::string>{"floor", "wave"}));
  const std::vector<RunInfo::RigidObject> objects{{"floor", true, true}, {"box", true, true}, {"wave", false, true}};
  EXPECT_EQ(back.objects, objects);
  // Writing what was read gives the same text.
  EXPECT_EQ(format_run_json(back.meta, back.progress, config), text);

  // Degenerate values: a running run (end_time null), no deformable edge (shortest_edge infinite,
  // written as null), nothing optional recorded.
  RunMeta bare;
  bare.contact = {0, 0, 0, 0, 0};
  bare.initial_proximity = InitialProximity{};
  bare.initial_proximity->shortest_edge = std::numeric_limits<double>::infinity();
  RunProgress running;
  running.status = "running";
  running.frames_written = 0;
  const RunInfo bare_back = parse_run_json(format_run_json(bare, running, "not json {"), "run.json");
  EXPECT_TRUE(bare_back.meta == bare);
  EXPECT_TRUE(bare_back.progress == running);
  EXPECT_FALSE(bare_back.progress.end_time.has_value());
}

TEST(RunJson, FilesWrittenByMainAreReadAndRewrittenByteForByte) {
  struct Case {
    const char* name;
    double r, xi, delta;  // as the scene files say (configs/physically_active.yaml, configs/drape.yaml)
  };
  for (const Case& c : {Case{"main_5311d93_physically_active.json", 0.005, 0.005, 0.002},
                        Case{"main_5311d93_drape.json", 0.005, 0.01, 0.0005}}) {
    SCOPED_TRACE(c.name);
    const std::string text = read_text(fixture(c.name));
    ASSERT_FALSE(text.empty());
    const RunInfo info = parse_run_json(text, fixture(c.name));
    EXPECT_EQ(without_build(format_run_json(info.meta, info.progress, config_of(text))),
              without_build(without_dropped_keys(text)));
    EXPECT_EQ(info.progress.status, "completed");
    EXPECT_EQ(info.progress.frames_written, 2);
    EXPECT_EQ(info.meta.contact.radius, c.r);
    EXPECT_EQ(info.meta.contact.offset, c.xi);
    EXPECT_EQ(info.meta.contact.repulsion_range, c.delta);
    EXPECT_EQ(info.meta.fps, 60.0);
    EXPECT_NE(info.meta.scene_fingerprint, 0u);
    ASSERT_TRUE(info.meta.initial_proximity.has_value());
  }
  const RunInfo active = parse_run_json(read_text(fixture("main_5311d93_physically_active.json")), "a");
  EXPECT_EQ(active.meta.scene, "physically_active");
  EXPECT_EQ(active.meta.contact.friction_static, 0.3);
  EXPECT_EQ(active.meta.contact.friction_kinetic, 0.2);
  EXPECT_EQ(active.meta.every, 2);
  EXPECT_EQ(active.objects, (std::vector<RunInfo::RigidObject>{{"ball", true, false}}));
  EXPECT_TRUE(active.obstacles.empty());
  const RunInfo drape = parse_run_json(read_text(fixture("main_5311d93_drape.json")), "d");
  EXPECT_EQ(drape.meta.scene_fingerprint, 0x6fcf01bd41a16884ULL);
  EXPECT_EQ(drape.meta.memory_estimate, 39192368.62725483);
  EXPECT_EQ(drape.progress.peak_resident_bytes, 19013632.0);
  EXPECT_EQ(drape.obstacles, (std::vector<std::string>{"ball"}));
  EXPECT_EQ(drape.objects, (std::vector<RunInfo::RigidObject>{{"ball", true, true}}));
  EXPECT_EQ(drape.meta.every, 1);
  EXPECT_EQ(drape.meta.formats, (std::vector<std::string>{"obj"}));
}

TEST(RunJson, OlderFilesWithoutTheNewerKeysAreRead) {
  // The keys of an early run.json: no broad_phase, argv, memory, fingerprint, initial_proximity,
  // vertices; a status that is not a string is taken as absent.
  const std::string old = R"({"ccfr": {"version": "0.0.9"}, "scene": "drape", "solver": "ccfr",
    "radius": 0.004, "offset": 0.008, "repulsion_range": 0.001, "fps": 30, "status": null,
    "config": {"output": {"every": 0}, "objects": [{"name": "floor", "kind": "obstacle", "animation": null}]}})";
  const RunInfo info = parse_run_json(old, "old/run.json");
  EXPECT_EQ(info.meta.contact.radius, 0.004);
  EXPECT_EQ(info.meta.contact.offset, 0.008);
  EXPECT_EQ(info.meta.contact.repulsion_range, 0.001);
  EXPECT_EQ(info.meta.fps, 30.0);
  EXPECT_EQ(info.meta.broad_phase, "");
  EXPECT_TRUE(info.meta.argv.empty());
  EXPECT_EQ(info.meta.scene_fingerprint, 0u);
  EXPECT_FALSE(info.meta.initial_proximity.has_value());
  EXPECT_EQ(info.progress.status, "");
  EXPECT_EQ(info.progress.frames_written, -1);
  EXPECT_EQ(info.meta.every, 1);  // output.every below 1 is read as 1
  EXPECT_EQ(info.objects, (std::vector<RunInfo::RigidObject>{{"floor", true, true}}));
}

TEST(RunJson, MalformedFilesAreOneErrorNamingTheFileAndKey) {
  auto message = [](const std::string& text) {
    try {
      (void)parse_run_json(text, "runs/a/run.json");
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  auto has = [](const std::string& s, const std::string& part) { return s.find(part) != std::string::npos; };
  const std::string no_radius = message(R"({"offset": 0.01, "repulsion_range": 0, "fps": 60})");
  EXPECT_TRUE(has(no_radius, "runs/a/run.json") && has(no_radius, "'radius' is missing")) << no_radius;
  const std::string text_offset = message(R"({"radius": 0.01, "offset": "0.01", "repulsion_range": 0, "fps": 60})");
  EXPECT_TRUE(has(text_offset, "'offset' is not a number")) << text_offset;
  const std::string bad_fp =
      message(R"({"radius": 1, "offset": 1, "repulsion_range": 0, "fps": 60, "scene_fingerprint": "xyz"})");
  EXPECT_TRUE(has(bad_fp, "'scene_fingerprint'")) << bad_fp;
  const std::string bad_mem = message(R"({"radius": 1, "offset": 1, "repulsion_range": 0, "fps": 60, "memory": {}})");
  EXPECT_TRUE(has(bad_mem, "'memory.estimate_bytes' is missing")) << bad_mem;
  const std::string bad_format = message(
      R"({"radius": 1, "offset": 1, "repulsion_range": 0, "fps": 60, "config": {"output": {"formats": ["gif"]}}})");
  EXPECT_TRUE(has(bad_format, "'config.output.formats'")) << bad_format;
  EXPECT_TRUE(has(message("{\"radius\": 0.01, "), "runs/a/run.json' is not valid JSON"));
  EXPECT_TRUE(has(message("[1, 2]"), "is not a JSON object"));
  EXPECT_TRUE(has(message(""), "is not valid JSON"));
}

TEST(RunJson, ReadRunInfoListsFramesAndNeedsRunJsonOnlyWhenAsked) {
  const fs::path dir = fs::temp_directory_path() / ("ccfr_run_json_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir / "frames");
  std::ofstream(dir / "frames/frame_00001.obj") << "v 0 0 0\n";
  std::ofstream(dir / "frames/frame_00000.obj") << "v 0 0 0\n";
  const RunInfo none = read_run_info(dir, /*require_run_json=*/false);
  EXPECT_FALSE(none.has_run_json);
  EXPECT_EQ(none.frames.size(), 2u);
  EXPECT_EQ(none.frames.front().filename(), "frame_00000.obj");
  EXPECT_THROW((void)read_run_info(dir), Error);
  fs::copy_file(fixture("main_5311d93_drape.json"), dir / "run.json");
  const RunInfo info = read_run_info(dir);
  EXPECT_TRUE(info.has_run_json);
  EXPECT_EQ(info.dir, dir);
  EXPECT_EQ(info.meta.scene, "drape");
  EXPECT_EQ(info.frames.size(), 2u);
  EXPECT_THROW((void)read_run_info(dir / "missing"), Error);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace ccfr::io
