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

namespace {

// run.json of a completed run whose config names the objects' kinds (the audit reads `kind`,
// `animation` and `pins` of config.objects) and output.every.
void write_run_json_with_objects(const fs::path& d, int frames_written, const std::string& objects, int every = 1) {
  std::ofstream(d / "run.json")
      << R"({"scene": "x", "solver": "ccfr", "radius": 0.02, "offset": 0.01, "repulsion_range": 0, "fps": 60, )"
      << R"("status": "completed", "frames_written": )" << frames_written << R"(, "config": {"output": {"every": )"
      << every << R"(}, "objects": [)" << objects << "]}}\n";
}

// One object of two triangles: f in the plane z = z0 and g standing on it with its lowest vertex
// `gap` above f's interior (a tooth over a spine). Vertices 1-3 are f, 4-6 are g.
// `base`: vertices before this object in the frame (OBJ indices are global).
std::string two_part(const std::string& name, double z0, double gap, int base = 0) {
  char b[512];
  std::snprintf(b, sizeof b,
                "o %s\nv 0 0 %.17g\nv 1 0 %.17g\nv 0 1 %.17g\nv 0.3 0.3 %.17g\nv 0.4 0.3 %.17g\n"
                "v 0.2 0.3 %.17g\nf %d %d %d\nf %d %d %d\n",
                name.c_str(), z0, z0, z0, z0 + gap, z0 + 1, z0 + 1, base + 1, base + 2, base + 3, base + 4, base + 5,
                base + 6);
  return b;
}

}  // namespace

// A frame missing from the middle of a sequence is refused with the frame named, never "all N
// frames checked"; a run written with output.every K has only every K-th frame, and that is no gap.
TEST(Audit, ASequenceWithAGapIsRefused) {
  const fs::path d = scratch("gap");
  write_run_json(d, "completed", 4);
  for (int f : {0, 1, 2, 4}) write_frame(d, f, kClean);
  auto r = run("audit " + d.string());
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("has a gap: 1 frame is missing between frame 0 and frame 4 (3)"), std::string::npos) << r.out;
  EXPECT_EQ(r.out.find("all 4 frames"), std::string::npos) << r.out;
  EXPECT_NE(read(d / "audit.json").find("\"verdict\": \"error\""), std::string::npos);
  // --partial accepts an unfinished run, not a hole in it.
  write_run_json(d, "running", 4);
  EXPECT_EQ(run("audit " + d.string() + " --partial").code, 2);
  write_frame(d, 3, kClean);
  write_run_json(d, "completed", 5);
  r = run("audit " + d.string());
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_EQ(last_line(r.out).rfind("PASS (all 5 frames checked)", 0), 0u) << r.out;

  // output.every 2: frames 0, 2, 4 and the last (5) are the whole run; 0, 4, 5 miss frame 2.
  const fs::path e = scratch("gap_every");
  for (int f : {0, 2, 4, 5}) write_frame(e, f, kClean);
  write_run_json_with_objects(e, 4, "", 2);
  r = run("audit " + e.string());
  EXPECT_EQ(r.code, 0) << r.out;
  fs::remove(e / "frames" / "frame_00002.obj");
  write_run_json_with_objects(e, 3, "", 2);
  r = run("audit " + e.string());
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("missing between frame 0 and frame 5 (2)"), std::string::npos) << r.out;

  // Without run.json the step is the smallest one present: 0, 10, 20, 40 miss 30.
  const fs::path g = scratch("gap_foreign");
  for (int f : {0, 10, 20, 40}) write_frame(g, f, kClean);
  r = run("audit " + g.string() + " --offset 0.01");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("(30)"), std::string::npos) << r.out;
  // Many missing frames are listed in part, with the count.
  for (int f : {0, 1}) write_frame(g, f, kClean);
  r = run("audit " + g.string() + " --offset 0.01");
  EXPECT_NE(r.out.find("36 frames are missing"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("and 16 more"), std::string::npos) << r.out;
}

// A rigid object whose parts nearly touch (a comb's teeth on its spine): translated rigidly, the
// rounding of its coordinates turns the near contact into a touching pair. Distances inside a rigid
// motion do not change, so that is no failure of the method; the same change in a deforming object
// is one, and a rigid object that deformed is caught as such.
TEST(Audit, PairsInsideARigidObjectThatMovedRigidlyAreNotViolations) {
  const fs::path d = scratch("rigid");
  // Frame 0: g's lowest vertex 1e-300 above f (no contact in exact arithmetic); frame 1: both
  // moved up by 0.1, where 0.1 + 1e-300 rounds to 0.1: g touches f.
  write_frame(d, 0, two_part("comb", 0.0, 1e-300) + two_part("other", 5.0, 0.5, 6));
  write_frame(d, 1, two_part("comb", 0.1, 1e-300) + two_part("other", 5.0, 0.5, 6));
  const std::string other = R"({"name": "other", "kind": "cloth"})";
  for (const char* kind : {"obstacle", "rigid"}) {
    write_run_json_with_objects(d, 2, std::string(R"({"name": "comb", "kind": ")") + kind + "\"}, " + other);
    const auto r = run("audit " + d.string());
    EXPECT_EQ(r.code, 0) << kind << "\n" << r.out;
    EXPECT_EQ(last_line(r.out).rfind("PASS (all 2 frames checked)", 0), 0u) << r.out;
    EXPECT_NE(r.out.find("1 rigid objects"), std::string::npos) << r.out;
    EXPECT_NE(read(d / "audit.json").find("\"rigid_objects\": 1"), std::string::npos);
  }
  // The same frames as a deforming object: a contact, the method's failure.
  write_run_json_with_objects(d, 2, R"({"name": "comb", "kind": "shell"}, )" + other);
  auto r = run("audit " + d.string());
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_NE(r.out.find("triangle-triangle intersection: face 0 - face 1"), std::string::npos) << r.out;
  // An obstacle animated by a sequence may deform, so its pairs are tested; no solver moves it,
  // so what they find is the scene's.
  write_run_json_with_objects(d, 2,
                              R"({"name": "comb", "kind": "obstacle", "animation": {"path": "a%d.obj"}}, )" + other);
  r = run("audit " + d.string());
  EXPECT_EQ(r.code, 5) << r.out;
  EXPECT_NE(r.out.find("face 0 - face 1 (objects 'comb' and 'comb')"), std::string::npos) << r.out;

  // A rigid body bent: its tooth pushed 0.05 through the spine. The deformation is a violation and
  // the pairs inside it are tested again.
  write_frame(d, 1, two_part("comb", 0.0, -0.05) + two_part("other", 5.0, 0.5, 6));
  write_run_json_with_objects(d, 2, R"({"name": "comb", "kind": "rigid"}, )" + other);
  r = run("audit " + d.string());
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_NE(r.out.find("rigid deformation: object 'comb' is no rigid transform of its reference shape: vertex 3"),
            std::string::npos)
      << r.out;
  EXPECT_NE(r.out.find("triangle-triangle intersection: face 0 - face 1"), std::string::npos) << r.out;
  EXPECT_NE(last_line(r.out).find("2 violations in 1 frames"), std::string::npos) << r.out;

  // A rotation by 90 degrees about z (exact in double) is rigid: nothing inside is tested.
  std::string turned = "o comb\n";
  for (const auto& p : std::vector<std::array<double, 3>>{
           {0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0.3, 0.3, 1e-300}, {0.4, 0.3, 1}, {0.2, 0.3, 1}}) {
    char b[128];
    std::snprintf(b, sizeof b, "v %.17g %.17g %.17g\n", -p[1], p[0], p[2] + 0.1);
    turned += b;
  }
  write_frame(d, 1, turned + "f 1 2 3\nf 4 5 6\n" + two_part("other", 5.0, 0.5, 6));
  r = run("audit " + d.string());
  EXPECT_EQ(r.code, 0) << r.out;
}

// Two scripted objects driven into each other (an obstacle spun through the floor): no solver can
// move either, so the method passes and the scene is flagged apart, with exit code 5. A cloth
// through the same floor is still the method's failure.
TEST(Audit, PairsBetweenScriptedObjectsAreASceneErrorNotAViolation) {
  const fs::path d = scratch("scene_error");
  const std::string floor = "o floor\nv -1 0 -1\nv 1 0 -1\nv 0 0 1\nf 1 2 3\n";
  auto arm = [](double y) {
    char b[256];
    std::snprintf(b, sizeof b, "o arm\nv 0 %.17g 0\nv 0.2 %.17g 0\nv 0 %.17g 0.2\nf 4 5 6\n", y, y + 1, y + 1);
    return std::string(b);
  };
  write_frame(d, 0, floor + arm(0.5));
  write_frame(d, 1, floor + arm(-0.5));  // through the floor
  write_frame(d, 2, floor + arm(0.5));
  write_run_json_with_objects(d, 3,
                              R"({"name": "floor", "kind": "obstacle"}, {"name": "arm", "kind": "obstacle", )"
                              R"("keyframes": [{"time": 0}]})");
  auto r = run("audit " + d.string());
  EXPECT_EQ(r.code, 5) << r.out;
  EXPECT_NE(r.out.find("PASS (all 3 frames checked)"), std::string::npos) << r.out;
  EXPECT_EQ(last_line(r.out).rfind("SCENE ERROR: the scene drives scripted objects into each other (not the method's "
                                   "failure): 1 pairs in 1 frames; first at frame 1: triangle-triangle intersection: "
                                   "face 0 - face 1 (objects 'floor' and 'arm')",
                                   0),
            0u)
      << r.out;
  const std::string j = read(d / "audit.json");
  for (const char* key : {"\"verdict\": \"pass\"", "\"exit_code\": 5", "\"scene_error\": true", "\"scene_pairs\": 1",
                          "\"first_scene_frame\": 1", "\"violations\": 0", "\"scripted_objects\": 2"})
    EXPECT_NE(j.find(key), std::string::npos) << key << "\n" << j;

  // A rigid body driven by pins is scripted too; a free rigid body is not.
  write_run_json_with_objects(d, 3,
                              R"({"name": "floor", "kind": "obstacle"}, {"name": "arm", "kind": "rigid", )"
                              R"("pins": [{"indices": [0]}]})");
  EXPECT_EQ(run("audit " + d.string()).code, 5);
  write_run_json_with_objects(d, 3, R"({"name": "floor", "kind": "obstacle"}, {"name": "arm", "kind": "rigid"})");
  EXPECT_EQ(run("audit " + d.string()).code, 1);
  write_run_json_with_objects(d, 3, R"({"name": "floor", "kind": "obstacle"}, {"name": "arm", "kind": "cloth"})");
  r = run("audit " + d.string());
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_EQ(r.out.find("SCENE ERROR"), std::string::npos) << r.out;
}

// A frame with a coordinate beyond ccfr's bound (1e6) or beyond double range is refused naming the
// frame file, line and vertex, by the audit, `export` and `render` alike (render used to abort in
// Embree; export wrote `inf` into float formats).
TEST(Audit, FramesWithCoordinatesBeyondTheBoundAreRefusedEverywhere) {
  const fs::path d = scratch("huge");
  write_run_json(d, "completed", 2);
  write_frame(d, 0, kClean);
  for (const char* bad : {"1e200", "-2e6", "1e39", "inf"}) {
    write_frame(d, 1,
                std::string("o a\nv 0 0 0\nv ") + bad + " 0 0\nv 0 1 0\nf 1 2 3\n" +
                    "o b\nv 0.2 0.2 1\nv 0.3 0.2 1\nv 0.2 0.3 1\nf 4 5 6\n");
    const std::string where = (d / "frames" / "frame_00001.obj").string() + ":3: vertex 2: ";
    for (const std::string cmd : {"audit " + d.string(), "export " + d.string() + " --format ply",
                                  "render " + d.string() + " --width 32 --height 24 --samples 1 --ao 0"}) {
      const auto r = run(cmd);
      EXPECT_EQ(r.code, 2) << bad << ": " << cmd << "\n" << r.out;
      EXPECT_NE(r.out.find(where), std::string::npos) << bad << ": " << cmd << "\n" << r.out;
      EXPECT_EQ(r.out.find("internal error"), std::string::npos) << r.out;
    }
  }
}

// `ccfr run` warns before simulating when the scene drives two obstacles into each other, at the
// first sampled frame where they come within xi: a block 0.5 above the floor falling at 0.9 m/s
// comes within xi = 0.01 when 0.5 - 0.9 t < 0.01, first at frame 33 of 60 fps (t = 0.55 s); the
// audit of that run passes the method and flags the scene.
TEST(Audit, RunWarnsWhenTheSceneDrivesObstaclesIntoEachOther) {
  const fs::path d = scratch("scripted_warning");
  auto scene = [&](const std::string& motion) {
    std::ofstream(d / "scene.yaml")
        << "scene: s\ntime: {fps: 60, frames: 40, substeps: 1}\ncontact: {radius: 0.02, offset: 0.01}\nobjects:\n"
           "  - name: floor\n    kind: obstacle\n    shape: {type: plane, size: 1, resolution: 2}\n"
           "  - name: block\n    kind: obstacle\n    shape: {type: box, size: [0.2, 0.2, 0.2]}\n"
           "    transform: {translate: [0, 0.6, 0]}\n"
        << motion
        << "  - name: sheet\n    kind: cloth\n    shape: {type: grid, size: [0.1, 0.1], resolution: [2, 2]}\n"
           "    transform: {translate: [5, 2, 0]}\n";
    // The whole run: the warning samples the frames the scene will simulate.
    return run("run " + (d / "scene.yaml").string() + " -q --out " + (d / "o").string() + " --force");
  };
  auto r = scene("    motion: {velocity: [0, -0.9, 0]}\n");
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("obstacles 'floor' and 'block' come closer than xi at frame 33 (t = 0.55 s; face "),
            std::string::npos)
      << r.out;
  EXPECT_NE(r.out.find("`ccfr audit` reports their pairs as a scene error"), std::string::npos) << r.out;
  r = run("audit " + (d / "o").string());
  EXPECT_EQ(r.code, 5) << r.out;
  EXPECT_NE(r.out.find("first at frame 33: "), std::string::npos) << r.out;
  // Moving away, or both static (touching or not), draws no warning.
  r = scene("    motion: {velocity: [0, 0.9, 0]}\n");
  EXPECT_EQ(r.out.find("obstacles '"), std::string::npos) << r.out;
  r = scene("");
  EXPECT_EQ(r.out.find("obstacles '"), std::string::npos) << r.out;
}

// The comb generator's teeth rest on its spine; moved by `motion`, the rounding of the translation
// turns near contacts inside it into touching pairs. Neither `ccfr audit` nor the in-simulation
// audit (debug.audit, which stopped this run at frame 1 with "9 penetration(s)") may count them.
TEST(Audit, AMovingCombIsCleanForTheRunAndTheAudit) {
  const fs::path d = scratch("comb");
  std::ofstream(d / "scene.yaml")
      << "scene: comb\ntime: {fps: 60, frames: 6, substeps: 4, iterations: 2}\n"
         "contact: {solver: ccfr, radius: 0.1, offset: 0.04, repulsion_range: 0.02}\n"
         "debug: {audit: every_frame}\nobjects:\n"
         "  - name: comb\n    kind: obstacle\n"
         "    shape: {type: comb, length: 2.0, width: 0.2, spine_height: 0.3, teeth: 16, tooth_length: 1.0, "
         "tooth_width: 0.06}\n"
         "    transform: {rotate_axis: [0, 0, 1], rotate_deg: 180, translate: [0, 0.5, -1]}\n"
         "    motion: {velocity: [0, 0, 1.3]}\n"
         "  - name: curtain\n    kind: strand\n"
         "    shape: {type: strands, count: 4, vertices: 10, length: 1, spread: 2.5, layout: row}\n"
         "    transform: {translate: [0, 4, 0]}\n    pins: [{box_min: [-3, 3.99, -1], box_max: [3, 4.01, 1]}]\n";
  auto r = run("run " + (d / "scene.yaml").string() + " -q --out " + (d / "out").string() + " --force");
  ASSERT_EQ(r.code, 0) << r.out;
  for (const std::string& p : ccfr::test::csv_column(d / "out" / "stats.csv", "penetrations")) EXPECT_EQ(p, "0");
  r = run("audit " + (d / "out").string());
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_EQ(last_line(r.out).rfind("PASS (all 7 frames checked)", 0), 0u) << r.out;
  // Without the roles (an audit of the bare frames with --offset) the same frames fail: the test
  // would prove nothing if the comb's own pairs did not flip.
  fs::rename(d / "out" / "run.json", d / "run.json.saved");
  r = run("audit " + (d / "out").string() + " --offset 0.04");
  EXPECT_EQ(r.code, 1) << r.out;
}

// Frames of another scene under this run's run.json: their vertex count differs from the run's,
// and the audit refuses them instead of certifying them (it used to PASS).
TEST(Audit, FramesWithAnotherVertexCountThanTheRunAreRefused) {
  const fs::path d = scratch("foreign_vertices");
  std::ofstream(d / "run.json")
      << R"({"scene": "x", "solver": "ccfr", "radius": 0.02, "offset": 0.01, "repulsion_range": 0, "fps": 60, )"
      << R"("status": "completed", "frames_written": 2, "vertices": 29})"
      << "\n";
  write_frame(d, 0, kClean);
  write_frame(d, 1, kClean);
  const auto r = run("audit " + d.string());
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("has 6 vertices, but"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("records 29"), std::string::npos) << r.out;
  EXPECT_EQ(r.out.find("PASS"), std::string::npos) << r.out;
}

// --offset beyond the scene's size excludes every pair as close in frame 0, so anything would
// pass: it is refused, naming the option and the size.
TEST(Audit, AnOffsetBeyondTheSceneIsRefused) {
  const fs::path d = scratch("huge_offset");
  write_frame(d, 0, kClean);
  write_frame(d, 1, kCrossing);
  for (const char* offset : {"1e300", "10"}) {
    const auto r = run("audit " + d.string() + " --offset " + offset);
    EXPECT_EQ(r.code, 2) << offset << ": " << r.out;
    EXPECT_NE(r.out.find("is larger than the scene"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("--offset "), std::string::npos) << r.out;
  }
  EXPECT_EQ(run("audit " + d.string() + " --offset 0.01").code, 1);
}

// Another run's frames of the same topology (the sheet placed elsewhere): the vertex count fits,
// but each frame carries its run's scene fingerprint, which differs from run.json's.
TEST(Audit, FramesOfAnotherSceneWithTheSameTopologyAreRefused) {
  const fs::path d = ccfr::test::scratch_dir("audit_other_fingerprint");
  const auto scene = [&](const std::string& name, const std::string& y) {
    return ccfr::test::write_text(d, name,
                                  "time: {frames: 2}\nobjects:\n  - {name: sheet, kind: cloth, shape: {type: grid, "
                                  "size: [0.1, 0.1], resolution: [2, 2]}, transform: {translate: [0, " +
                                      y + ", 0]}}\n");
  };
  for (const auto& [name, y] : {std::pair<std::string, std::string>{"a", "0"}, {"b", "1"}}) {
    const auto r = run("run " + scene(name + ".yaml", y).string() + " --out " + (d / name).string() + " -q");
    ASSERT_EQ(r.code, 0) << r.out;
  }
  EXPECT_EQ(run("audit " + (d / "a").string()).code, 0);
  fs::remove_all(d / "a" / "frames");
  fs::copy(d / "b" / "frames", d / "a" / "frames");
  const auto r = run("audit " + (d / "a").string());
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("scene fingerprint"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("not this run's"), std::string::npos) << r.out;
}

// A rerun killed while it replaced DIR leaves the earlier run in DIR.ccfr-old: the audit and
// --resume of DIR point to it instead of saying only "no run.json".
TEST(Audit, AMissingRunPointsToTheEarlierRunLeftByAKilledRerun) {
  const fs::path root = ccfr::test::scratch_dir("audit_ccfr_old");
  const fs::path dir = root / "run", old = root / "run.ccfr-old";
  fs::create_directories(dir / "frames");
  fs::create_directories(old / "frames");
  write_run_json(old, "completed", 1);
  for (const std::string& cmd : {"audit " + dir.string(), "run --resume " + dir.string()}) {
    const auto r = run(cmd);
    EXPECT_EQ(r.code, 2) << cmd << "\n" << r.out;
    EXPECT_NE(r.out.find("its earlier run is in '" + old.string() + "'"), std::string::npos) << cmd << "\n" << r.out;
  }
  fs::remove_all(dir);
  const auto r = run("audit " + dir.string());
  EXPECT_NE(r.out.find("its earlier run is in '" + old.string() + "'"), std::string::npos) << r.out;
}
