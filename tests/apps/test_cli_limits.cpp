// Command-line bounds: readable ranges, a cap on --threads, and 32-bit integers from --set.
#include <gtest/gtest.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

#include "cli_support.hpp"

namespace fs = std::filesystem;

namespace {
using Result = ccfr::test::CliResult;
Result run(const std::string& args) { return ccfr::test::run_ccfr(args); }

fs::path scene_dir() {
  const fs::path d = ccfr::test::scratch_dir("cli_limits");
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
