// Every command-line and input mistake ends in exit 2 with a message naming the path, key or
// option (issue 37): paths that cannot be looked at (symlink loops, names too long, permission
// denied) in every subcommand, CLI11's parse errors, global options after nested subcommands,
// empty solver names, damaged sweep.json and run.json, strict sweep specs checked before any
// cell runs, and `ccfr plot` on a stats.csv ccfr did not write.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "cli_support.hpp"

namespace fs = std::filesystem;
using ccfr::test::CliResult;
using ccfr::test::run_ccfr;
using ccfr::test::run_shell;

namespace {

bool has(const CliResult& r, const std::string& s) { return r.out.find(s) != std::string::npos; }

fs::path scene(const fs::path& d) {
  std::ofstream(d / "s.yaml") << "time: {frames: 1, substeps: 1}\n"
                                 "objects:\n"
                                 "  - {name: sheet, kind: cloth, shape: {type: grid, size: [0.1, 0.1], resolution: "
                                 "[2, 2]}}\n";
  return d / "s.yaml";
}

std::string q(const fs::path& p) { return "'" + p.string() + "'"; }

}  // namespace

// `filesystem error: status: ...` was an internal error (exit 3) in every subcommand.
TEST(CliErrors, PathsThatCannotBeLookedAtAreExit2NamingThePath) {
  const fs::path d = ccfr::test::scratch_dir("cli_errors_paths");
  fs::create_symlink(d / "loop_b", d / "loop_a");
  fs::create_symlink(d / "loop_a", d / "loop_b");
  const fs::path s = scene(d);
  for (const fs::path& bad : std::vector<fs::path>{d / "loop_a", d / (std::string(300, 'x') + ".yaml")}) {
    for (const std::string& cmd :
         std::vector<std::string>{"run " + q(bad) + " --out " + q(d / "o"), "audit " + q(bad), "render " + q(bad),
                                  "export " + q(bad) + " --format ply", "plot " + q(bad), "bench " + q(bad),
                                  "ablate " + q(bad) + " --out " + q(d / "ab"),

                                  "run --resume " + q(bad), "sweep status " + q(bad)}) {
      SCOPED_TRACE(cmd);
      const CliResult r = run_ccfr(cmd);
      EXPECT_EQ(r.code, 2) << r.out;
      EXPECT_FALSE(has(r, "internal error")) << r.out;
      EXPECT_TRUE(has(r, bad.filename().string().substr(0, 40))) << r.out;
    }
  }
  // A mesh path in the scene that loops names the scene key.
  std::ofstream(d / "m.yaml") << "objects:\n  - {name: m, kind: obstacle, shape: {type: mesh, path: loop_a.obj}}\n";
  fs::create_symlink(d / "loop_b.obj", d / "loop_a.obj");
  fs::create_symlink(d / "loop_a.obj", d / "loop_b.obj");
  const CliResult r = run_ccfr("run " + q(d / "m.yaml") + " --out " + q(d / "o3"));
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_TRUE(has(r, "objects[0].shape.path")) << r.out;
}

// CLI11 exits 104-109 on its parse errors; ccfr documents 2 for every user error.
TEST(CliErrors, CommandLineErrorsExit2) {
  const fs::path d = ccfr::test::scratch_dir("cli_errors_parse");
  const fs::path s = scene(d);
  for (const std::string& cmd :
       std::vector<std::string>{"run " + q(s) + " --out " + q(d / "o") + " --frames -1", "frobnicate",
                                "run " + q(s) + " extra --out " + q(d / "o"), "run " + q(s) + " --no-such-option",
                                "export " + q(d), "", "sweep status"}) {
    SCOPED_TRACE(cmd);
    const CliResult r = run_ccfr(cmd);
    EXPECT_EQ(r.code, 2) << r.out;
  }
  EXPECT_EQ(run_ccfr("--help").code, 0);
  EXPECT_EQ(run_ccfr("run --help").code, 0);
  EXPECT_EQ(run_ccfr("--version").code, 0);
  EXPECT_FALSE(fs::exists(d / "o"));
}

// -q and --log-level go after any subcommand, nested ones included; a bad level is refused everywhere.
TEST(CliErrors, GlobalOptionsAfterEverySubcommand) {
  const fs::path d = ccfr::test::scratch_dir("cli_errors_global");
  const fs::path s = scene(d);
  for (const std::string& sub : std::vector<std::string>{"status", "resume", "collect"})
    for (const std::string& opt : std::vector<std::string>{"-q", "--log-level warn", "--quiet --log-level error"}) {
      SCOPED_TRACE(sub + " " + opt);
      const CliResult r = run_ccfr("sweep " + sub + " " + q(d) + " " + opt);
      EXPECT_EQ(r.code, 2) << r.out;  // d is no sweep: the command itself ran and said so
      EXPECT_TRUE(has(r, "is not a sweep directory")) << r.out;
      EXPECT_FALSE(has(r, "not expected")) << r.out;
    }
  for (const std::string& cmd : std::vector<std::string>{
           "sweep --log-level bogus", "sweep status " + q(d) + " --log-level bogus",
           "ablate " + q(s) + " --out " + q(d / "ab") + " --log-level bogus",
           "run " + q(s) + " --out " + q(d / "o") + " --log-level bogus", "--log-level bogus audit " + q(d)}) {
    SCOPED_TRACE(cmd);
    const CliResult r = run_ccfr(cmd);
    EXPECT_EQ(r.code, 2) << r.out;
    EXPECT_TRUE(has(r, "--log-level")) << r.out;
    EXPECT_TRUE(has(r, "bogus")) << r.out;
  }
  EXPECT_FALSE(fs::exists(d / "ab"));
  EXPECT_FALSE(fs::exists(d / "o"));
  // Only the global options reach a nested subcommand: sweep's own options and positional do not.
  for (const std::string& extra : std::vector<std::string>{"--backend slurm", "--out " + q(d / "x"), "spec.yaml"}) {
    SCOPED_TRACE(extra);
    const CliResult r = run_ccfr("sweep status " + q(d) + " " + extra);
    EXPECT_EQ(r.code, 2) << r.out;
    EXPECT_TRUE(has(r, "not expected")) << r.out;
  }
  const CliResult ok = run_ccfr("run " + q(s) + " --out " + q(d / "o") + " -q --log-level error");
  EXPECT_EQ(ok.code, 0) << ok.out;
}

TEST(CliErrors, EmptySolverNamesAreRefused) {
  const fs::path d = ccfr::test::scratch_dir("cli_errors_solver");
  const fs::path s = scene(d);
  for (const std::string& cmd : std::vector<std::string>{
           "run " + q(s) + " --out " + q(d / "o") + " --solver ''", "bench " + q(s) + " --solver ''",
           "ablate " + q(s) + " --out " + q(d / "ab") + " --solvers ''"}) {
    SCOPED_TRACE(cmd);
    const CliResult r = run_ccfr(cmd);
    EXPECT_EQ(r.code, 2) << r.out;
    EXPECT_TRUE(has(r, "is empty")) << r.out;
  }
  EXPECT_FALSE(fs::exists(d / "o"));
  EXPECT_FALSE(fs::exists(d / "ab"));
}

// {"cells": 5} was an internal error (nlohmann type_error) in status and resume.
TEST(CliErrors, DamagedSweepJsonIsAnErrorNamingIt) {
  const fs::path d = ccfr::test::scratch_dir("cli_errors_sweepjson");
  for (const std::string& json :
       std::vector<std::string>{R"({"cells": 5})", R"({"cells": [1]})", R"({"cells": [], "parameters": 3})"}) {
    std::ofstream(d / "sweep.json") << json;
    for (const std::string& sub : std::vector<std::string>{"status", "resume", "collect"}) {
      SCOPED_TRACE(sub + " " + json);
      const CliResult r = run_ccfr("sweep " + sub + " " + q(d));
      EXPECT_EQ(r.code, 2) << r.out;
      EXPECT_TRUE(has(r, "sweep.json' is damaged")) << r.out;
      EXPECT_FALSE(has(r, "internal error")) << r.out;
    }
  }
}

// A sweep spec is checked whole before any cell runs: duplicate keys, unknown solvers and keys
// of `parameters` or `set` the scene schema does not have.
TEST(CliErrors, StrictSweepSpecsFailBeforeAnyCellRuns) {
  const fs::path d = ccfr::test::scratch_dir("cli_errors_spec");
  const fs::path s = scene(d);
  const std::string configs = "configs: [" + s.string() + "]\n";
  struct Case {
    std::string spec, key, says;
    int line;
  };
  for (const Case& c : std::vector<Case>{
           {configs + "solvers: [ccfr]\nsolvers: [post_process]\n", "solvers", "duplicate key 'solvers'", 3},
           {configs + "set: {time.fps: 30, time.fps: 60}\n", "set.time.fps", "duplicate key", 2},
           {configs + "solvers: [ccfr, nosuch]\n", "solvers[1]", "unknown contact solver 'nosuch'", 2},
           {configs + "parameters:\n  contact.no_such_key: [1, 2]\n", "parameters.contact.no_such_key", "unknown key",
            3},
           {configs + "parameters:\n  contact.radius: [0.01, -5]\n", "parameters.contact.radius", "out of range", 3},
           {configs + "set: {time.no_such: 3}\n", "set.time.no_such", "unknown key", 2},
           {configs + "solvers: [ccfr]\nset: {contact.exact_projection.anything: 3}\n",
            "set.contact.exact_projection.anything", "unknown key 'exact_projection'", 3},
           // A key that is no key path (null, a list, a map) is bad input, not an internal error.
           {configs + "parameters:\n  ~: [1, 2]\n", "parameters", "expected a key path", 3},
           {configs + "parameters:\n  [contact.offset]: [1, 2]\n", "parameters", "expected a key path", 3},
           {configs + "set: {{time.fps: 1}: 3}\n", "set", "expected a key path", 2},
           {configs + "cases:\n  - {[contact.offset]: 0.01}\n", "cases[0]", "expected a key path", 3},
           // A case's bad value is blamed on that case.
           {configs + "cases:\n  - {contact.radius: 0.01}\n  - {contact.radius: -5}\n", "cases[1].contact.radius",
            "out of range", 4},
       }) {
    SCOPED_TRACE(c.spec);
    std::ofstream(d / "spec.yaml") << c.spec;
    fs::remove_all(d / "sw");
    const CliResult r = run_ccfr("sweep " + q(d / "spec.yaml") + " --out " + q(d / "sw"));
    EXPECT_EQ(r.code, 2) << r.out;
    EXPECT_TRUE(has(r, "spec.yaml:" + std::to_string(c.line) + ": '" + c.key + "'")) << r.out;
    EXPECT_TRUE(has(r, c.says)) << r.out;
    EXPECT_FALSE(fs::exists(d / "sw" / "sweep.json")) << r.out;  // no cell was laid out, none ran
  }
}

// A run.json cut short said "no run.json"; the user sees the file and is told it is not there.
TEST(CliErrors, TruncatedRunJsonIsCalledTruncated) {
  const fs::path d = ccfr::test::scratch_dir("cli_errors_runjson");
  fs::create_directories(d / "run");
  std::ofstream(d / "run" / "run.json") << R"({"ccfr": {"version": "0.1", "git_co)";
  const CliResult r = run_ccfr("run --resume " + q(d / "run"));
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_TRUE(has(r, "run.json is unreadable")) << r.out;
  EXPECT_TRUE(has(r, "truncated")) << r.out;
  EXPECT_FALSE(has(r, "no run.json")) << r.out;
  // A new run into it says the same, rather than "no run.json".
  std::ofstream(d / "s.yaml") << "time: {frames: 1, substeps: 1}\nobjects:\n  - {name: sheet, kind: cloth, shape: "
                                 "{type: grid, size: [0.1, 0.1], resolution: [2, 2]}}\n";
  const CliResult rerun = run_ccfr("run " + q(d / "s.yaml") + " --out " + q(d / "run"));
  EXPECT_EQ(rerun.code, 2) << rerun.out;
  EXPECT_TRUE(has(rerun, "run.json is unreadable")) << rerun.out;
  EXPECT_FALSE(has(rerun, "no run.json")) << rerun.out;
  fs::remove(d / "run" / "run.json");
  EXPECT_TRUE(has(run_ccfr("run --resume " + q(d / "run")), "no run.json"));
}

TEST(CliErrors, PlotRefusesAForeignStatsCsvAndPrintsTheFileItWrote) {
  const fs::path d = ccfr::test::scratch_dir("cli_errors_plot");
  const fs::path s = scene(d);
  ASSERT_EQ(run_ccfr("run " + q(s) + " --out " + q(d / "run") + " -q").code, 0);
  const std::string good = ccfr::test::read_text(d / "run" / "stats.csv");
  fs::create_directories(d / "bad");
  for (const std::string& csv :
       std::vector<std::string>{std::string("hello,world\n1,2\n"), good + "1,2,three\n",
                                good.substr(0, good.find('\n') + 1) + "1,2\n3,4\n", std::string("\x7f\x45LF\x02")}) {
    SCOPED_TRACE(csv.substr(0, 40));
    std::ofstream(d / "bad" / "stats.csv", std::ios::binary) << csv;
    const CliResult r = run_ccfr("plot " + q(d / "bad"));
    EXPECT_EQ(r.code, 2) << r.out;
    EXPECT_TRUE(has(r, "stats.csv")) << r.out;
    EXPECT_FALSE(fs::exists(d / "bad" / "stats.png"));
  }
  // A run cut short mid-row is still ccfr's: it plots. --out without an extension names the .png.
  std::ofstream(d / "run" / "stats.csv", std::ios::binary) << good << "2,0.03";
  const CliResult r = run_ccfr("plot " + q(d / "run") + " --out " + q(d / "base"));
  if (r.code == 2 && has(r, "matplotlib")) GTEST_SKIP() << "no python3-matplotlib: " << r.out;
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_TRUE(fs::exists(d / "base.png")) << r.out;
  EXPECT_TRUE(has(r, "plot: " + (d / "base.png").string() + " in ")) << r.out;
  // A folder as --out gets stats.png inside it, not DIR.png beside it.
  fs::create_directories(d / "pngs");
  const CliResult in_dir = run_ccfr("plot " + q(d / "run") + " --out " + q(d / "pngs"));
  EXPECT_EQ(in_dir.code, 0) << in_dir.out;
  EXPECT_TRUE(fs::exists(d / "pngs" / "stats.png")) << in_dir.out;
  EXPECT_FALSE(fs::exists(d / "pngs.png")) << in_dir.out;
}

// bench --frames 0 has nothing to measure: said so, not blamed on the default --warmup 0.
TEST(CliErrors, BenchWithoutFramesSaysSo) {
  const fs::path d = ccfr::test::scratch_dir("cli_errors_bench0");
  const CliResult r = run_ccfr("bench " + q(scene(d)) + " --frames 0");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_TRUE(has(r, "at least one frame to measure")) << r.out;
  EXPECT_TRUE(has(r, "--frames is 0")) << r.out;
  EXPECT_FALSE(has(r, "--warmup")) << r.out;
}

// Permission denied on a directory in the path (EACCES from stat). Root passes every permission
// check, so the commands run as `nobody` through runuser; skipped where that is not possible.
TEST(CliErrors, InaccessiblePathsAreExit2NamingThePath) {
  if (::geteuid() != 0 || std::system("command -v runuser > /dev/null 2>&1") != 0)
    GTEST_SKIP() << "needs root and runuser to run ccfr as nobody";
  const fs::path d = ccfr::test::nobody_scratch_dir("cli_errors_eacces");
  const fs::path exe = ccfr::test::nobody_exe(d);
  fs::permissions(d, fs::perms::owner_all | fs::perms::others_read | fs::perms::others_exec);
  scene(d);
  fs::create_directories(d / "closed");
  fs::copy_file(d / "s.yaml", d / "closed" / "s.yaml");
  fs::permissions(d / "closed", fs::perms::none);
  for (const std::string& cmd : std::vector<std::string>{
           "run " + q(d / "closed" / "s.yaml") + " --out /tmp/ccfr_eacces_never", "audit " + q(d / "closed" / "x"),
           "plot " + q(d / "closed" / "x"), "render " + q(d / "closed" / "x"), "bench " + q(d / "closed" / "s.yaml")}) {
    SCOPED_TRACE(cmd);
    const CliResult r = run_shell("runuser -u nobody -- " + exe.string() + " " + cmd + " 2>&1");
    EXPECT_EQ(r.code, 2) << r.out;
    EXPECT_TRUE(has(r, "Permission denied")) << r.out;
    EXPECT_TRUE(has(r, (d / "closed").string())) << r.out;
    EXPECT_FALSE(has(r, "internal error")) << r.out;
  }
  fs::permissions(d / "closed", fs::perms::owner_all);
  // A render folder that cannot be made under a read-only one says why (it named the folder only).
  ASSERT_EQ(run_ccfr("run " + q(d / "s.yaml") + " --out " + q(d / "run") + " -q").code, 0);
  fs::permissions(d / "run", fs::perms::owner_all | fs::perms::others_read | fs::perms::others_exec);
  fs::permissions(d / "run" / "frames", fs::perms::owner_all | fs::perms::others_read | fs::perms::others_exec);
  for (const auto& e : fs::directory_iterator(d / "run" / "frames"))
    fs::permissions(e.path(), fs::perms::others_read, fs::perm_options::add);
  fs::permissions(d / "run" / "run.json", fs::perms::others_read, fs::perm_options::add);
  fs::create_directories(d / "readonly");
  fs::permissions(d / "readonly", fs::perms::owner_all | fs::perms::others_read | fs::perms::others_exec);
  const CliResult r = run_shell("runuser -u nobody -- " + exe.string() + " render " + q(d / "run") + " --out " +
                                q(d / "readonly" / "sub") + " --width 16 --height 16 --samples 1 --ao 0 2>&1");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_TRUE(has(r, "cannot create the output folder")) << r.out;
  EXPECT_TRUE(has(r, "Permission denied")) << r.out;
}

// A message quotes what the user wrote; YAML escapes ("\e", "\u009b") put terminal control
// sequences into values, so every error is printed with its control characters as \xNN.
TEST(CliErrors, MessagesNeverCarryTerminalControlSequences) {
  const fs::path d = ccfr::test::scratch_dir("cli_errors_escape");
  std::ofstream(d / "e.yaml") << "objects:\n  - {name: s, kind: \"\\e[31mred\\u009b2J\", shape: {type: grid, size: "
                                 "[1, 1], resolution: [2, 2]}}\n";
  const CliResult r = run_ccfr("run " + q(d / "e.yaml") + " --out " + q(d / "o"));
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_TRUE(has(r, "objects[0].kind")) << r.out;
  EXPECT_FALSE(has(r, "\x1b")) << r.out;
  EXPECT_FALSE(has(r, "\xc2\x9b")) << r.out;
  EXPECT_TRUE(has(r, "\\x1b[31mred\\xc2\\x9b2J")) << r.out;
}

// The unknown-command message offers the commands --help lists, not the hidden help-markdown.
TEST(CliErrors, UnknownCommandListsTheVisibleCommandsOnly) {
  const CliResult r = run_ccfr("frobnicate");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_TRUE(has(r, "unknown command 'frobnicate'; the commands are run, audit,")) << r.out;
  EXPECT_FALSE(has(r, "help-markdown")) << r.out;
}
