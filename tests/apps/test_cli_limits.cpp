// Command-line bounds: readable ranges, a cap on --threads, and 32-bit integers from --set.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>

#include <array>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>

#include "cli_support.hpp"

namespace fs = std::filesystem;

namespace {
using Result = ccfr::test::CliResult;
Result run(const std::string& args) { return ccfr::test::run_ccfr(args); }

/// The running test's own folder: ctest runs each test as its own process, in parallel, and a
/// folder shared by them was emptied by one while another wrote in it.
fs::path scene_dir() {
  const fs::path d = ccfr::test::scratch_dir(std::string("cli_limits/") +
                                             ::testing::UnitTest::GetInstance()->current_test_info()->name());
  std::ofstream(d / "s.yaml")
      << "time: {frames: 1, substeps: 1}\n"
         "objects:\n"
         "  - {name: sheet, kind: cloth, shape: {type: grid, size: [0.1, 0.1], resolution: [2, 2]}}\n";
  return d;
}

bool has(const Result& r, const std::string& s) { return r.out.find(s) != std::string::npos; }
}  // namespace

TEST(CliLimits, ThreadsAreCappedWithAClearMessage) {
  const fs::path d = scene_dir();
  const Result r = run("run " + (d / "s.yaml").string() + " --out " + (d / "out").string() + " --threads 2147483647");
  EXPECT_NE(r.code, 0) << r.out;
  EXPECT_TRUE(has(r, "--threads")) << r.out;
  EXPECT_TRUE(has(r, "at most 1024")) << r.out;
  EXPECT_FALSE(fs::exists(d / "out" / "run.json")) << r.out;
}

TEST(CliLimits, RangesAreReadable) {
  const fs::path d = scene_dir();
  const Result r = run("run " + (d / "s.yaml").string() + " --out " + (d / "out").string() + " --frames -1");
  EXPECT_NE(r.code, 0) << r.out;
  EXPECT_TRUE(has(r, ">= 0")) << r.out;
  EXPECT_FALSE(has(r, "17976931348623157")) << r.out;  // DBL_MAX printed in full
  const Result help = run("run --help");
  EXPECT_FALSE(has(help, "17976931348623157")) << help.out;
  const Result audit = run("audit " + d.string() + " --stride 0");
  EXPECT_NE(audit.code, 0);
  EXPECT_FALSE(has(audit, "17976931348623157")) << audit.out;
}

TEST(CliLimits, HugeIntegersFromSetNameTheOption) {
  const fs::path d = scene_dir();
  const Result r =
      run("run " + (d / "s.yaml").string() + " --out " + (d / "out").string() + " --set time.substeps=3000000000");
  EXPECT_NE(r.code, 0) << r.out;
  EXPECT_TRUE(has(r, "--set time.substeps=3000000000")) << r.out;
  EXPECT_TRUE(has(r, "out of range")) << r.out;
  EXPECT_FALSE(has(r, "internal error")) << r.out;
}

// --max-memory sets the limit the loader's estimate is held to (max_memory): 0.01 GB is below the
// 26 MB base of any scene, so the 9-vertex sheet is refused, naming it and the option; the
// default (what the machine has available) runs it.
TEST(CliLimits, MaxMemoryIsTheLimitOfTheEstimate) {
  const fs::path d = scene_dir();
  const std::string base = "run " + (d / "s.yaml").string() + " --out " + (d / "out").string() + " --force";
  const Result low = run(base + " --max-memory 0.01");
  EXPECT_NE(low.code, 0) << low.out;
  EXPECT_TRUE(has(low, "'sheet' (cloth, 9 vertices)")) << low.out;
  EXPECT_TRUE(has(low, "of max_memory")) << low.out;
  EXPECT_TRUE(has(low, "--max-memory")) << low.out;
  EXPECT_FALSE(fs::exists(d / "out" / "run.json")) << low.out;
  const Result negative = run(base + " --max-memory -1");
  EXPECT_NE(negative.code, 0) << negative.out;
  const Result fine = run(base + " --max-memory 1");
  EXPECT_EQ(fine.code, 0) << fine.out;
}

// A run that outgrows its memory limit stops after the frame that crossed it, before the machine
// swaps or kills it: exit 1, run.json says why and how much it held, every frame on disk is whole,
// and a checkpoint lets the run resume where the memory is. A block of 3375 particles packed at
// less than the reach pairs with itself from frame 1 (about 50 MB); the limit is lowered for the
// one run with CCFR_RUN_MEMORY_LIMIT_MB, because no scene is estimated below its peak.
TEST(CliLimits, ARunThatOutgrowsItsMemoryStopsWithItsFramesWhole) {
  const fs::path d = ccfr::test::scratch_dir("memory_stop");
  std::ofstream(d / "block.yaml") << "scene: block\ntime: {fps: 60, frames: 3}\n"
                                     "contact: {radius: 0.005, offset: 0.004, repulsion_range: 0.001}\n"
                                     "output: {checkpoint_every: 10}\n"
                                     "materials: {sand: {density: 1500}}\n"
                                     "objects:\n"
                                     "  - {name: block, kind: particles, material: sand, shape: {type: particles, "
                                     "counts: [15, 15, 15], spacing: 0.005}}\n";
  const std::string out = (d / "out").string();
  const Result r = ccfr::test::run_shell("CCFR_RUN_MEMORY_LIMIT_MB=25 " + std::string(CCFR_EXE) + " run " +
                                         (d / "block.yaml").string() + " --out " + out + " 2>&1");
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_TRUE(has(r, "memory: the run holds")) << r.out;
  EXPECT_TRUE(has(r, "after frame 1, more than the 25 MB of CCFR_RUN_MEMORY_LIMIT_MB")) << r.out;
  std::ifstream rj(d / "out" / "run.json");
  const std::string json((std::istreambuf_iterator<char>(rj)), std::istreambuf_iterator<char>());
  EXPECT_NE(json.find("\"status\": \"failed: memory: the run holds"), std::string::npos) << json;
  EXPECT_NE(json.find("\"peak_resident_bytes\""), std::string::npos) << json;
  EXPECT_NE(json.find("\"frames_written\": 2"), std::string::npos) << json;
  EXPECT_TRUE(fs::exists(d / "out" / "frames" / "frame_00001.obj"));
  EXPECT_FALSE(fs::exists(d / "out" / "frames" / "frame_00002.obj"));
  EXPECT_TRUE(fs::exists(d / "out" / "checkpoints" / "checkpoint_00001.ccfr"));
  // Where the memory is, the run resumes and completes, and the audit certifies every frame.
  const Result resumed = run("run --resume " + out);
  EXPECT_EQ(resumed.code, 0) << resumed.out;
  const Result audit = run("audit " + out);
  EXPECT_EQ(audit.code, 0) << audit.out;
  EXPECT_TRUE(fs::exists(d / "out" / "frames" / "frame_00003.obj"));
}

// --max-memory below a megabyte used to print as 0.000000 and mean "no limit"; inf was reported as
// `--set max_memory=inf`. Both are now the option's own errors.
TEST(CliLimits, MaxMemoryTinyOrInfiniteNamesTheOption) {
  const fs::path d = scene_dir();
  const std::string base = "run " + (d / "s.yaml").string() + " --out " + (d / "out").string() + " --force";
  for (const char* v : {"1e-7", "inf", "nan", "2e6"}) {
    const Result r = run(base + " --max-memory " + v);
    EXPECT_NE(r.code, 0) << v << ": " << r.out;
    EXPECT_TRUE(has(r, "--max-memory")) << r.out;
    EXPECT_FALSE(has(r, "--set max_memory")) << r.out;
    EXPECT_FALSE(fs::exists(d / "out" / "run.json")) << r.out;
  }
}

// A frame too long to finish (10000 substeps of 10000 sweeps) still stops on a second SIGINT:
// the frame in progress is abandoned, the frames on disk stay whole. It used to need SIGKILL.
TEST(CliLimits, ASecondSignalAbandonsALongFrame) {
  const fs::path d = ccfr::test::scratch_dir("long_frame_signal");
  std::ofstream(d / "s.yaml") << "time: {frames: 2, substeps: 10000, xpbd_sweeps: 10000}\n"
                                 "objects:\n"
                                 "  - {name: sheet, kind: cloth, shape: {type: grid, size: [1, 1], resolution: [30, "
                                 "30]}}\n";
  const fs::path out = d / "out";
  const pid_t pid = ccfr::test::spawn_ccfr({"run", (d / "s.yaml").string(), "--out", out.string()}, d / "log");
  int status = 0;
  const auto waited = [&](double seconds) {
    const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
    while (std::chrono::steady_clock::now() < end) {
      if (::waitpid(pid, &status, WNOHANG) == pid) return true;
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    return false;
  };
  for (int i = 0; i < 3000 && !fs::exists(out / "frames" / "frame_00000.obj"); ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  ASSERT_FALSE(waited(0.5)) << ccfr::test::read_text(d / "log");
  ::kill(pid, SIGINT);
  ASSERT_FALSE(waited(0.5)) << ccfr::test::read_text(d / "log");  // the first one lets the frame finish
  ::kill(pid, SIGINT);
  const bool ended = waited(20);
  if (!ended) {
    ::kill(pid, SIGKILL);
    ::waitpid(pid, &status, 0);
  }
  const std::string log = ccfr::test::read_text(d / "log");
  ASSERT_TRUE(ended) << "still running 20 s after a second SIGINT:\n" << log;
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 1) << log;
  EXPECT_NE(log.find("interrupted during frame 1"), std::string::npos) << log;
  EXPECT_FALSE(fs::exists(out / "frames" / "frame_00001.obj")) << log;
  EXPECT_NE(ccfr::test::read_text(out / "run.json").find("interrupted during frame 1"), std::string::npos);
}

// A solver's range error prints a huge value as 1e+300, not its 301 digits.
TEST(CliLimits, HugeValuesInSolverErrorsAreShort) {
  const fs::path d = scene_dir();
  const Result r = run("run " + (d / "s.yaml").string() + " --out " + (d / "out").string() +
                       " --set contact.solver=dat --set contact.dat.query_radius=1e300");
  EXPECT_EQ(r.code, 2) << r.out;
  // Short, and named as the schema's errors are: the --set that gave it and the key path.
  EXPECT_TRUE(has(r,
                  "error: command line (--set contact.dat.query_radius=1e300): 'contact.dat.query_radius': "
                  "1e+300 must be"))
      << r.out;
  EXPECT_FALSE(has(r, "100000000000000005")) << r.out;
}

// contact.radius 1e-9 freezes a lone cloth: its carry (a body touching nothing moves rigidly, at
// most r per pass) is capped every pass. The capped speed is said, as stats.csv's
// clamped_vertices promises, not only counted.
TEST(CliLimits, ATinyRadiusThatFreezesALoneClothIsWarnedAbout) {
  const fs::path d = ccfr::test::scratch_dir("tiny_radius");
  std::ofstream(d / "s.yaml")
      << "time: {frames: 1, substeps: 1}\ncontact: {radius: 1e-9}\nobjects:\n"
         "  - {name: sheet, kind: cloth, shape: {type: grid, size: [1, 1], resolution: [4, 4]}}\n";
  const Result r = run("run " + (d / "s.yaml").string() + " --out " + (d / "out").string());
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_TRUE(has(r, "object 'sheet' wants to move")) << r.out;
  EXPECT_TRUE(has(r, "counted in clamped_vertices")) << r.out;
}

// --frames takes time.frames' bound itself: it used to be reported as `--set time.frames=N`.
TEST(CliLimits, FramesBeyondTheBoundNameTheOption) {
  const fs::path d = scene_dir();
  const Result r = run("run " + (d / "s.yaml").string() + " --out " + (d / "out").string() + " --frames 20000000");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_TRUE(has(r, "--frames")) << r.out;
  EXPECT_FALSE(has(r, "--set time.frames")) << r.out;
}
