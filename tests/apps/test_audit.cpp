// `ccfr audit` on hand-made run directories: what it refuses, what it reports, its exit codes
// and DIR/audit.json.
#include <gtest/gtest.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include "cli_support.hpp"

namespace fs = std::filesystem;

namespace {

using Result = ccfr::test::CliResult;
Result run(const std::string& args) { return ccfr::test::run_ccfr(args); }
std::string read(const fs::path& p) { return ccfr::test::read_text(p); }
fs::path scratch(const std::string& name) {
  const fs::path d = ccfr::test::scratch_dir("audit_" + name);
  fs::create_directories(d / "frames");
  return d;
}

std::string last_line(const std::string& s) {
  const size_t end = s.find_last_not_of('\n');
  if (end == std::string::npos) return "";
  const size_t begin = s.rfind('\n', end);
  return s.substr(begin == std::string::npos ? 0 : begin + 1, end - (begin == std::string::npos ? 0 : begin + 1) + 1);
}

// Triangle a in the plane z = 0; triangle b either 1 above it (clean) or through it (one
// intersecting triangle pair, nothing else within xi = 0.01).
const char* kClean = "o a\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\no b\nv 0.2 0.2 1\nv 0.3 0.2 1\nv 0.2 0.3 1\nf 4 5 6\n";
const char* kCrossing =
    "o a\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\no b\nv 0.2 0.2 -0.5\nv 0.3 0.2 0.5\nv 0.2 0.3 0.5\nf 4 5 6\n";

void write_frame(const fs::path& d, int n, const std::string& text) {
  char name[32];
  std::snprintf(name, sizeof name, "frame_%05d.obj", n);
  std::ofstream(d / "frames" / name) << text;
}

void write_run_json(const fs::path& d, const std::string& status, int frames_written) {
  std::ofstream(d / "run.json")
      << R"({"scene": "x", "solver": "ccfr", "radius": 0.02, "offset": 0.01, "repulsion_range": 0, "fps": 60, )"
      << R"("status": ")" << status << R"(", "frames_written": )" << frames_written << "}\n";
}

}  // namespace

// A sheet stuck in the floor in every frame: with frame 0 missing, the first frame present must
// not become the reference that excuses the intersection.
TEST(Audit, MissingFrameZeroIsRefusedUnlessAReferenceIsGiven) {
  const fs::path d = scratch("noframe0");
  write_run_json(d, "completed", 2);
  write_frame(d, 1, kCrossing);
  write_frame(d, 2, kCrossing);
  const auto r = run("audit " + d.string());
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("frame_00000.obj' is missing"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("--reference"), std::string::npos) << r.out;

  std::ofstream(d / "rest.obj") << kClean;
  const auto f = run("audit " + d.string() + " --reference " + (d / "rest.obj").string());
  EXPECT_EQ(f.code, 1) << f.out;
  EXPECT_EQ(last_line(f.out).rfind("FAIL (all 2 frames checked): 2 violations in 2 frames; first at frame 1", 0), 0u)
      << f.out;
  EXPECT_NE(f.out.find("initial proximity from " + (d / "rest.obj").string() +
                       ": 0 adjacent sub-pairs closer than xi and 0 intersecting"),
            std::string::npos)
      << f.out;

  // The reference decides the exclusions even when frame 0 exists: frame 0 is then audited too.
  write_frame(d, 0, kCrossing);
  write_run_json(d, "completed", 3);
  EXPECT_EQ(run("audit " + d.string()).code, 0);  // frame 0 excludes the pair: consistent with the docs
  const auto g = run("audit " + d.string() + " --reference " + (d / "rest.obj").string());
  EXPECT_EQ(g.code, 1) << g.out;
  EXPECT_NE(g.out.find("3 violations in 3 frames; first at frame 0"), std::string::npos) << g.out;

  std::ofstream(d / "other.obj") << "o a\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
  const auto t = run("audit " + d.string() + " --reference " + (d / "other.obj").string());
  EXPECT_EQ(t.code, 2) << t.out;
  EXPECT_NE(t.out.find("differs from the reference"), std::string::npos) << t.out;
  EXPECT_EQ(run("audit " + d.string() + " --reference " + (d / "none.obj").string()).code, 2);
}

// Elements the audit would not check as what they are are refused with file and line.
TEST(Audit, ElementsTheAuditCannotCheckAreRefused) {
  const fs::path d = scratch("mixed");
  write_run_json(d, "completed", 2);
  // Frame 0 clean, frame 1 with the element moved onto / through the triangle.
  auto audit_frames = [&](const std::string& frame0, std::string frame1 = "") {
    write_frame(d, 0, frame0);
    write_frame(d, 1, frame1.empty() ? frame0 : frame1);
    return run("audit " + d.string());
  };
  // A point lying on the triangle of its own block in frame 1 (distance 0 < xi as a particle).
  auto r = audit_frames("o a\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 0.2 0.2 1\nf 1 2 3\np 4\n",
                        "o a\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 0.2 0.2 0\nf 1 2 3\np 4\n");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("frame_00000.obj:7: object 'a' mixes faces (f) and points (p)"), std::string::npos) << r.out;
  // As its own block, the same point is audited and fails.
  r = audit_frames("o a\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\no dust\nv 0.2 0.2 1\np 4\n",
                   "o a\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\no dust\nv 0.2 0.2 0\np 4\n");
  EXPECT_EQ(r.code, 1) << r.out;

  // A segment through the triangle of its own block: only a strand segment is tested against triangles.
  r = audit_frames("o a\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 0.2 0.2 0.5\nv 0.2 0.2 1.5\nf 1 2 3\nl 4 5\n",
                   "o a\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 0.2 0.2 -0.5\nv 0.2 0.2 0.5\nf 1 2 3\nl 4 5\n");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("frame_00000.obj:8: object 'a' mixes faces (f) and lines (l)"), std::string::npos) << r.out;
  r = audit_frames("o a\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\no hair\nv 0.2 0.2 0.5\nv 0.2 0.2 1.5\nl 4 5\n",
                   "o a\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\no hair\nv 0.2 0.2 -0.5\nv 0.2 0.2 0.5\nl 4 5\n");
  EXPECT_NE(r.out.find("segment through triangle"), std::string::npos) << r.out;
  EXPECT_EQ(r.code, 1) << r.out;

  // Vertices without any element, free-form geometry and included files would not be audited.
  r = audit_frames(std::string(kClean) + "o cloud\nv 0.2 0.2 0\n");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("frame_00000.obj:11: object 'cloud' has 1 vertices but no f, l or p element"), std::string::npos)
      << r.out;
  r = audit_frames(std::string(kClean) + "curv 0 1 1 2\n");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("frame_00000.obj:11: unsupported OBJ statement 'curv'"), std::string::npos) << r.out;
  r = audit_frames(std::string(kClean) + "call more.obj\n");
  EXPECT_EQ(r.code, 2) << r.out;

  // Quads, negative indices, texture coordinates, groups of display state are read: clean here.
  r = audit_frames("o a\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\ns off\nusemtl x\nf -4/1 -3/1 -2/1 -1/1\n");
  EXPECT_EQ(r.code, 0) << r.out;

  // A file in frames/ the audit would skip by its name.
  write_frame(d, 0, kClean);
  write_frame(d, 1, kClean);
  std::ofstream(d / "frames" / "frame_0002b.obj") << kCrossing;
  r = run("audit " + d.string());
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("frame_0002b.obj' is not named frame_<number>.obj"), std::string::npos) << r.out;
}

TEST(Audit, RunStatusMustBeCompletedUnlessPartial) {
  const fs::path d = scratch("status");
  write_frame(d, 0, kClean);
  write_frame(d, 1, kClean);
  write_run_json(d, "running", 0);  // a killed run never rewrites run.json
  auto r = run("audit " + d.string());
  EXPECT_EQ(r.code, 4) << r.out;
  EXPECT_NE(r.out.find("run status: running"), std::string::npos) << r.out;
  EXPECT_EQ(last_line(r.out).rfind("INCOMPLETE (partial run, status 'running'; all 2 frames checked)", 0), 0u) << r.out;
  r = run("audit " + d.string() + " --partial");
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_EQ(last_line(r.out).rfind("PASS (partial run, status 'running'; all 2 frames checked)", 0), 0u) << r.out;

  write_run_json(d, "failed: frame 2: vertex 3 left its region", 2);
  EXPECT_EQ(run("audit " + d.string()).code, 4);
  write_run_json(d, "interrupted after frame 1", 2);
  EXPECT_EQ(run("audit " + d.string()).code, 4);
  write_run_json(d, "completed", 2);
  r = run("audit " + d.string());
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_EQ(last_line(r.out).rfind("PASS (all 2 frames checked)", 0), 0u) << r.out;
  // A completed run whose frames on disk do not match what it wrote.
  write_run_json(d, "completed", 3);
  r = run("audit " + d.string());
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("records 3 frames written"), std::string::npos) << r.out;
  // Penetrations outrank an unfinished status.
  write_run_json(d, "running", 0);
  write_frame(d, 1, kCrossing);
  EXPECT_EQ(run("audit " + d.string()).code, 1);
}

TEST(Audit, ReportIsWrittenToAuditJson) {
  const fs::path d = scratch("json");
  write_run_json(d, "completed", 3);
  write_frame(d, 0, kClean);
  write_frame(d, 1, kCrossing);
  write_frame(d, 2, kClean);
  const auto r = run("audit " + d.string());
  ASSERT_EQ(r.code, 1) << r.out;
  const std::string j = read(d / "audit.json");
  for (const char* key :
       {"\"verdict\": \"fail\"", "\"exit_code\": 1", "\"status\": \"completed\"", "\"partial\": false",
        "\"offset\": 0.01", "\"offset_source\": \"run.json\"", "\"tolerance\": 1e-06", "\"stride\": 1",
        "\"frames_checked\": 3", "\"frames_total\": 3", "\"vertices\": 6", "\"faces\": 2",
        "\"excluded_close_pairs\": 0", "\"excluded_intersections\": 0", "\"bad_frames\": 1", "\"first_bad_frame\": 1",
        "{\"frame\": 0, \"file\": \"frame_00000.obj\", \"triangle_intersections\": 0, \"segment_crossings\": 0, "
        "\"close_pairs\": 0, \"min_distance\": null, \"examples\": []}",
        "{\"frame\": 1, \"file\": \"frame_00001.obj\", \"triangle_intersections\": 1, \"segment_crossings\": 0, "
        "\"close_pairs\": 0, \"min_distance\": null, \"examples\": [\"triangle-triangle",
        "{\"frame\": 2, \"file\": \"frame_00002.obj\", \"triangle_intersections\": 0"})
    EXPECT_NE(j.find(key), std::string::npos) << key << "\n" << j;
  for (const auto& e : fs::directory_iterator(d))
    EXPECT_EQ(e.path().filename().string().find("audit.json.tmp"), std::string::npos) << "temporary file left behind";

  // An audit that cannot run replaces the earlier report rather than leaving it standing.
  write_frame(d, 1, "o a\nv 0 0 0\nv nan 0 0\n");
  ASSERT_EQ(run("audit " + d.string()).code, 2);
  const std::string e = read(d / "audit.json");
  EXPECT_NE(e.find("\"verdict\": \"error\""), std::string::npos) << e;
  EXPECT_NE(e.find("frame_00001.obj:3"), std::string::npos) << e;

  // --json writes elsewhere.
  write_frame(d, 1, kClean);
  ASSERT_EQ(run("audit " + d.string() + " --json " + (d / "elsewhere.json").string()).code, 0);
  EXPECT_NE(read(d / "elsewhere.json").find("\"verdict\": \"pass\""), std::string::npos);
}

// Any simulator's OBJ sequence: --offset stands in for run.json; the verdict says what was checked.
TEST(Audit, OffsetAloneAuditsForeignFramesAndStrideIsStated) {
  const fs::path d = scratch("foreign");
  for (int f = 0; f < 7; ++f) write_frame(d, f, kClean);
  auto r = run("audit " + d.string());
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("run.json' is missing: pass --offset"), std::string::npos) << r.out;

  r = run("audit " + d.string() + " --offset 0.01");
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("run status: unknown (no run.json)"), std::string::npos) << r.out;
  EXPECT_EQ(last_line(r.out).rfind("PASS (all 7 frames checked): ", 0), 0u) << r.out;
  r = run("audit " + d.string() + " --offset 0.01 --stride 3");
  EXPECT_EQ(last_line(r.out).rfind("PASS (every 3rd frame: 3 of 7 checked): ", 0), 0u) << r.out;
  r = run("audit " + d.string() + " --offset 0.01 --stride 4");
  EXPECT_EQ(last_line(r.out).rfind("PASS (every 4th frame and the last: 3 of 7 checked): ", 0), 0u) << r.out;
  const std::string j = read(d / "audit.json");
  for (const char* key : {"\"stride\": 4", "\"frames_checked\": 3", "\"frames_total\": 7", "\"status\": null",
                          "\"offset_source\": \"--offset\"", "{\"frame\": 4,", "{\"frame\": 6,"})
    EXPECT_NE(j.find(key), std::string::npos) << key << "\n" << j;
  EXPECT_EQ(j.find("{\"frame\": 3,"), std::string::npos) << j;
  // A frame skipped by the stride is not looked at: the verdict says so by its count.
  write_frame(d, 1, kCrossing);
  EXPECT_EQ(run("audit " + d.string() + " --offset 0.01 --stride 4").code, 0);
  EXPECT_EQ(run("audit " + d.string() + " --offset 0.01").code, 1);
}
