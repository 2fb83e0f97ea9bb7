// Everyday use of the ccfr executable: results on stdout and logs/progress on stderr, --quiet and
// --log-level, closing summaries, bench's option checks and integer counts, the advice `ccfr run`
// gives on r and ξ, and `ccfr plot` finding its scripts and its Python.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "cli_support.hpp"

namespace fs = std::filesystem;

namespace {
using ccfr::test::run_ccfr_split;

bool has(const std::string& text, const std::string& what) { return text.find(what) != std::string::npos; }

// Sheet edges 0.2 / 4 = 0.05; ξ = 0.005 is 0.1 of that; the sheet is still: no advice.
const std::string kScene = ccfr::test::sheet_on_floor_scene("everyday");

fs::path write_scene(const std::string& name, const std::string& yaml = kScene) {
  const fs::path d = ccfr::test::scratch_dir("everyday_" + name);
  std::ofstream(d / "scene.yaml") << yaml;
  return d;
}

}  // namespace

TEST(Everyday, RunPrintsResultsOnStdoutAndLogsAndProgressOnStderr) {
  const fs::path d = write_scene("streams");
  const auto r = run_ccfr_split("run " + (d / "scene.yaml").string() + " --out " + (d / "out").string(), d);
  ASSERT_EQ(r.code, 0) << r.out << r.err;
  // The closing summary: where the output is, the time, the contact figures and the next command.
  EXPECT_TRUE(has(r.out, "completed: 3 frames, output in " + fs::absolute(d / "out").string())) << r.out;
  EXPECT_TRUE(has(r.out, "s/frame); solver ccfr, ")) << r.out;
  EXPECT_TRUE(has(r.out, "next: ccfr audit " + fs::absolute(d / "out").string())) << r.out;
  EXPECT_FALSE(has(r.out, "[info]")) << r.out;
  // Logs and per-frame progress (a log line each without a terminal) with elapsed time and ETA.
  EXPECT_TRUE(has(r.err, "[info] scene 'everyday'")) << r.err;
  EXPECT_TRUE(has(r.err, "frame 1/3: elapsed ")) << r.err;
  EXPECT_TRUE(has(r.err, ", ETA ")) << r.err;
  EXPECT_TRUE(has(r.err, "frame 3/3: elapsed ")) << r.err;
  EXPECT_FALSE(has(r.err, "completed:")) << r.err;
  EXPECT_FALSE(has(r.err, "warn")) << r.err;  // the scene is within the advice's ranges
}

TEST(Everyday, QuietAndLogLevelApplyBeforeOrAfterTheSubcommand) {
  const fs::path d = write_scene("quiet");
  const std::string scene = (d / "scene.yaml").string();
  for (const std::string& args : {"run " + scene + " --out " + (d / "a").string() + " --quiet",
                                  "-q run " + scene + " --out " + (d / "b").string(),
                                  "--log-level warn run " + scene + " --out " + (d / "c").string(),
                                  "run " + scene + " --out " + (d / "d").string() + " --log-level error"}) {
    const auto r = run_ccfr_split(args, d);
    ASSERT_EQ(r.code, 0) << args << "\n" << r.out << r.err;
    EXPECT_TRUE(r.err.empty()) << args << "\n" << r.err;
    EXPECT_TRUE(has(r.out, "completed: 3 frames")) << args << "\n" << r.out;
  }
  // The explicit level wins over --quiet's warn, in either order; --quiet still hides progress.
  const auto debug = run_ccfr_split("-q run " + scene + " --out " + (d / "e").string() + " --log-level debug", d);
  ASSERT_EQ(debug.code, 0) << debug.err;
  EXPECT_TRUE(has(debug.err, "[debug]")) << debug.err;
  // Audit's default level is warn: its progress shows at info, its table and verdict on stdout.
  const auto audit = run_ccfr_split("audit " + (d / "a").string() + " --log-level info", d);
  ASSERT_EQ(audit.code, 0) << audit.out << audit.err;
  EXPECT_TRUE(has(audit.out, "PASS (all 4 frames checked)")) << audit.out;
  EXPECT_TRUE(has(audit.err, "audit frame 1/4: elapsed ")) << audit.err;
  EXPECT_TRUE(has(audit.err, "audit frame 4/4: elapsed ")) << audit.err;
  const auto quiet_audit = run_ccfr_split("audit " + (d / "a").string(), d);
  EXPECT_TRUE(quiet_audit.err.empty()) << quiet_audit.err;
  const auto bad = run_ccfr_split("run " + scene + " --log-level loud", d);
  EXPECT_EQ(bad.code, 2) << bad.err;  // a command-line error, like every user error (was CLI11 105)
  EXPECT_TRUE(has(bad.err, "loud")) << bad.err;
}

TEST(Everyday, BenchRefusesAWarmupThatLeavesNothingAndPrintsCountsAsIntegers) {
  const fs::path d = write_scene("bench");
  const std::string scene = (d / "scene.yaml").string();
  const auto equal = run_ccfr_split("bench " + scene + " --frames 2 --warmup 2", d);
  EXPECT_EQ(equal.code, 2) << equal.out << equal.err;
  EXPECT_TRUE(has(equal.err,
                  "--warmup 2 leaves no frame to measure: it must be smaller than the 2 frames simulated "
                  "(--frames)"))
      << equal.err;
  EXPECT_TRUE(equal.out.empty()) << equal.out;
  // From the scene's time.frames (3), before any simulation.
  const auto scene_frames = run_ccfr_split("bench " + scene + " --warmup 40", d);
  EXPECT_EQ(scene_frames.code, 2);
  EXPECT_TRUE(has(scene_frames.err, "smaller than the 3 frames simulated (time.frames of " + scene + ")"))
      << scene_frames.err;

  // The counts of a bench match the same run's stats.csv (single thread: the same frames).
  const auto bench = run_ccfr_split("bench " + scene + " --warmup 1 --threads 1", d);
  ASSERT_EQ(bench.code, 0) << bench.out << bench.err;
  const auto run = run_ccfr_split("run " + scene + " --out " + (d / "out").string() + " --threads 1", d);
  ASSERT_EQ(run.code, 0) << run.err;
  const auto candidates = ccfr::test::csv_column(d / "out" / "stats.csv", "candidates");
  ASSERT_EQ(candidates.size(), 3u);
  const long expected_max = std::max(std::stol(candidates[1]), std::stol(candidates[2]));
  std::stringstream lines(bench.out);
  bool found = false;
  for (std::string line; std::getline(lines, line);) {
    if (line.rfind("candidates", 0) != 0) continue;
    std::stringstream cells(line.substr(std::string("candidates").size()));
    std::string median, mean, max;
    cells >> median >> mean >> max;
    EXPECT_EQ(max, std::to_string(expected_max)) << line;
    EXPECT_EQ(max.find('.'), std::string::npos) << line;
    found = true;
  }
  EXPECT_TRUE(found) << bench.out;
  EXPECT_TRUE(has(bench.out, "count (per frame)")) << bench.out;
  EXPECT_TRUE(has(bench.out, "status: completed; 3 frames in ")) << bench.out;
}

TEST(Everyday, RunWarnsWhenTheOffsetIsLargeAgainstTheEdgesOrMotionOutrunsR) {
  // ξ = 0.04 against 0.05 edges: 0.80 of the shortest edge, above the 0.5 advised.
  std::string yaml = kScene;
  yaml.replace(yaml.find("offset: 0.005"), 13, "offset: 0.04");
  const fs::path d = write_scene("advice_offset", yaml);
  const auto r = run_ccfr_split("run " + (d / "scene.yaml").string() + " --frames 0 --out " + (d / "o").string(), d);
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_TRUE(has(r.err, "contact.offset (xi) = 0.04 is 0.80 times the shortest edge of object 'sheet' (0.05)"))
      << r.err;
  EXPECT_TRUE(has(r.err, "Use xi <= 0.025 or edges of at least 0.08")) << r.err;

  // The floor rises at 3 m/s: 3 / 120 = 0.025 per substep against r = 0.01, so 3 pieces per
  // substep; ceil(3 / (60 * 0.01)) = 5 substeps would keep it within r. The sheet starts at
  // 1.5 m/s: 0.0125 per substep, ceil(1.5 / 0.6) = 3 substeps.
  std::string moving = kScene;
  moving += "    motion: {velocity: [0, 3, 0]}\n";
  moving.replace(moving.find("    transform: {translate: [0, 0.02, 0]}"), 0, "    velocity: [1.5, 0, 0]\n");
  const fs::path m = write_scene("advice_speed", moving);
  const auto s = run_ccfr_split("run " + (m / "scene.yaml").string() + " --frames 0 --out " + (m / "o").string(), m);
  ASSERT_EQ(s.code, 0) << s.err;
  EXPECT_TRUE(has(s.err,
                  "object 'floor': scripted motion up to 3 m/s covers 0.025 per substep, more than r = 0.01; "
                  "every substep is split into 3 pieces"))
      << s.err;
  EXPECT_TRUE(has(s.err, "Set time.substeps to at least 5 or contact.radius to at least 0.025")) << s.err;
  EXPECT_TRUE(has(s.err, "object 'sheet': initial velocity 1.5 m/s covers 0.0125 per substep")) << s.err;
  EXPECT_TRUE(has(s.err, "Set time.substeps to at least 3 or contact.radius to at least 0.0125")) << s.err;
}

TEST(Everyday, PlotDrawsARunAndSaysWhatIsMissing) {
  const fs::path d = write_scene("plot");
  ASSERT_EQ(run_ccfr_split("run " + (d / "scene.yaml").string() + " --out " + (d / "out").string(), d).code, 0);
  const auto r = run_ccfr_split("plot " + (d / "out").string(), d);
  ASSERT_EQ(r.code, 0) << r.out << r.err;
  EXPECT_TRUE(has(r.out, "plot: " + (d / "out" / "stats.png").string())) << r.out;
  std::ifstream png(d / "out" / "stats.png", std::ios::binary);
  char magic[8] = {};
  png.read(magic, 8);
  EXPECT_EQ(std::string(magic + 1, 3), "PNG");

  const auto no_python = run_ccfr_split("plot " + (d / "out").string(), d, "CCFR_PYTHON=/nonexistent/python3");
  EXPECT_EQ(no_python.code, 2);
  EXPECT_TRUE(has(no_python.err, "error: no plot drawn: CCFR_PYTHON=/nonexistent/python3 is not an executable"))
      << no_python.err;
  // /bin/false stands for a python3 without matplotlib: `import matplotlib` exits non-zero.
  const auto no_mpl = run_ccfr_split("plot " + (d / "out").string(), d, "CCFR_PYTHON=/bin/false");
  EXPECT_EQ(no_mpl.code, 2);
  EXPECT_TRUE(has(no_mpl.err,
                  "matplotlib is not installed for python3 (tried /bin/false; apt-get install "
                  "python3-matplotlib)"))
      << no_mpl.err;
  const auto not_a_run = run_ccfr_split("plot " + d.string(), d);
  EXPECT_EQ(not_a_run.code, 2);
  EXPECT_TRUE(has(not_a_run.err, "holds neither stats.csv (a run) nor ablation.csv")) << not_a_run.err;
}

TEST(Everyday, AnInstalledCcfrFindsItsScriptsUnderThePrefix) {
  // A copy of the executable in PREFIX/bin with a marker script in PREFIX/share/ccfr/scripts: the
  // plot comes from the prefix, not from the source tree compiled into the binary.
  const fs::path d = write_scene("prefix");
  ASSERT_EQ(run_ccfr_split("run " + (d / "scene.yaml").string() + " --out " + (d / "out").string(), d).code, 0);
  const fs::path prefix = d / "prefix";
  fs::create_directories(prefix / "bin");
  fs::create_directories(prefix / "share" / "ccfr" / "scripts");
  fs::copy_file(CCFR_EXE, prefix / "bin" / "ccfr");
  std::ofstream(prefix / "share" / "ccfr" / "scripts" / "plot_stats.py")
      << "import sys\nopen(sys.argv[sys.argv.index('--out') + 1], 'w').write('from the prefix')\n";
  const std::string exe = (prefix / "bin" / "ccfr").string();
  const std::string cmd = exe + " plot " + (d / "out").string() + " --out " + (d / "marker.txt").string() + " 2>&1";
  FILE* p = popen(cmd.c_str(), "r");
  ASSERT_NE(p, nullptr);
  char buf[512];
  std::string out;
  while (size_t n = fread(buf, 1, sizeof buf, p)) out.append(buf, n);
  ASSERT_EQ(pclose(p), 0) << out;
  EXPECT_EQ(ccfr::test::read_text(d / "marker.txt"), "from the prefix");
}

TEST(Everyday, RenderFramesTheSubjectNotTheFloor) {
  // A 10 m floor centred 3 m to the side of a 0.2 m sheet at the origin: fitted to everything the
  // camera looks near x = 3 (the floor's centre dominates the bounds); fitted to the sheet, at its
  // centre, x = 0 within the sheet's own size.
  std::string yaml = kScene;
  yaml.replace(yaml.find("shape: {type: plane, size: 1.0, resolution: 2}"), 47,
               "shape: {type: plane, size: 10.0, resolution: 2}\n    transform: {translate: [3, 0, 0]}");
  const fs::path d = write_scene("frame", yaml);
  ASSERT_EQ(run_ccfr_split("run " + (d / "scene.yaml").string() + " --frames 1 --out " + (d / "out").string(), d).code,
            0);
  auto target_x = [&](const std::string& extra) {
    const auto r = run_ccfr_split("render " + (d / "out").string() + " --out " + (d / "png").string() +
                                      " --width 16 --height 12 --samples 1 --ao 0 --no-shadows" + extra,
                                  d);
    EXPECT_EQ(r.code, 0) << r.out << r.err;
    const size_t at = r.out.find(" target ");
    EXPECT_NE(at, std::string::npos) << r.out;
    return at == std::string::npos ? NAN : std::stod(r.out.substr(at + 8));
  };
  EXPECT_LT(std::abs(target_x("")), 0.1);
  EXPECT_GT(target_x(" --frame-all"), 2.0);
}

// The README's promise: every command's stdout ends with the command to run next, and that command
// is one that works here (each is run in turn: audit -> render -> plot, ablate -> plot, sweep
// status -> sweep collect, bench -> run).
TEST(Everyday, EveryCommandEndsWithTheCommandToRunNext) {
  const fs::path d = write_scene("next");
  const std::string scene = (d / "scene.yaml").string();
  const auto next_of = [](const std::string& out) {
    std::string last = out.substr(0, out.find_last_not_of('\n') + 1);
    last = last.substr(last.find_last_of('\n') + 1);
    const size_t at = last.find("next: ccfr ");
    EXPECT_NE(at, std::string::npos) << out;
    return at == std::string::npos ? std::string() : last.substr(at + 11);
  };
  const auto run = [&](const std::string& args) {
    const auto r = run_ccfr_split(args, d);
    EXPECT_EQ(r.code, 0) << args << "\n" << r.out << r.err;
    return r.out;
  };
  const std::string dir = (d / "r").string();
  EXPECT_EQ(next_of(run("run '" + scene + "' --frames 2 --out '" + dir + "'")), "audit " + dir);
  EXPECT_EQ(next_of(run("audit '" + dir + "'")), "render " + dir + " --sheet");
  EXPECT_EQ(next_of(run("render '" + dir + "' --sheet --width 32 --height 24")), "plot " + dir);
  EXPECT_EQ(next_of(run("plot '" + dir + "'")), "render " + dir);
  const std::string ab = (d / "ab").string();
  EXPECT_EQ(next_of(run("ablate '" + scene + "' --frames 1 --solvers none,ccfr --no-plot --out '" + ab + "'")),
            "plot " + ab);
  EXPECT_EQ(next_of(run("plot '" + ab + "'")), "render " + ab + "/none");  // the first solver's run
  EXPECT_EQ(next_of(run("sweep status '" + ab + "'")), "sweep collect " + ab);
  EXPECT_EQ(next_of(run("bench '" + scene + "' --frames 1")), "run " + scene + " --out out/scene");
}
