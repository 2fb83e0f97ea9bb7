// Progress of the multi-run commands (`ccfr ablate`, `ccfr sweep` with the local backend, `ccfr
// sweep status`): one progress over every cell, in frames, with elapsed time and ETA, on stderr
// as log lines (no terminal here); the closing summary on stdout; --quiet silences the progress.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>
#include <string>

#include "cli_support.hpp"

namespace fs = std::filesystem;
using ccfr::test::run_ccfr_split;

namespace {

bool has(const std::string& text, const std::string& what) { return text.find(what) != std::string::npos; }

// Every stderr line is one whole log line: cells log to their own files, never interleaved here.
void expect_only_log_lines(const std::string& err) {
  std::istringstream in(err);
  for (std::string line; std::getline(in, line);)
    EXPECT_TRUE(std::regex_search(line, std::regex(R"(^\[\d\d:\d\d:\d\d\.\d{3}\] \[(info|warning)\] )"))) << line;
}

// The frames done that the progress lines report never go back and never pass the total.
void expect_monotonic(const std::string& err, const std::string& label, long total) {
  const std::regex line(label + R"( frames (\d+)/(\d+):)");
  long last = 0, lines = 0;
  for (auto it = std::sregex_iterator(err.begin(), err.end(), line); it != std::sregex_iterator(); ++it, ++lines) {
    const long done = std::stol((*it)[1]);
    EXPECT_EQ(std::stol((*it)[2]), total) << it->str();
    EXPECT_GE(done, last) << err;
    EXPECT_LE(done, total) << it->str();
    last = done;
  }
  EXPECT_GT(lines, 0) << err;
  EXPECT_EQ(last, total) << err;
}

fs::path scene_dir(const std::string& name) {
  const fs::path d = ccfr::test::scratch_dir("sweep_progress_" + name);
  std::ofstream(d / "scene.yaml") << ccfr::test::sheet_on_floor_scene("progress");  // 3 frames
  return d;
}

}  // namespace

TEST(SweepProgress, AblateReportsFramesOfEverySolverWithEtaOverTheWholeAblation) {
  const fs::path d = scene_dir("ablate");
  const auto r = run_ccfr_split("ablate " + (d / "scene.yaml").string() +
                                    " --solvers ccfr,none --threads 1 --no-plot --out " + (d / "a").string(),
                                d);
  ASSERT_EQ(r.code, 0) << r.out << r.err;
  // 2 solvers x 3 frames. When ccfr ends, 3 of 6 frames are done and `none` has just started (a
  // loaded machine may let it write a frame or two first): the ETA is over both.
  EXPECT_TRUE(std::regex_search(r.err, std::regex(R"(ablate frames [3-5]/6: elapsed [^,]+, ETA [^;]+; 1/2 cells )"
                                                  R"(done; none frame [0-2]/3)")))
      << r.err;
  EXPECT_TRUE(has(r.err, "ablate: [1/2] ccfr: completed (exit 0) in ")) << r.err;
  EXPECT_TRUE(has(r.err, "ablate: [2/2] none: completed (exit 0) in ")) << r.err;
  // The last line: everything done, no ETA left.
  EXPECT_TRUE(std::regex_search(r.err, std::regex(R"(ablate frames 6/6: elapsed [^,;]+; 2/2 cells done\n)"))) << r.err;
  expect_only_log_lines(r.err);
  expect_monotonic(r.err, "ablate", 6);
  // stdout: the table and the summary, no log line.
  EXPECT_TRUE(has(r.out, "| `ccfr` | 3 |")) << r.out;
  EXPECT_TRUE(std::regex_search(r.out, std::regex(R"(ablate: 2 solvers, 6 frames in [^(]+\([^)]+/frame\), 0 )"
                                                  R"(failed to run, 2 of 2 passed the audit; tables in )")))
      << r.out;
  EXPECT_FALSE(has(r.out, "[info]")) << r.out;

  const auto q = run_ccfr_split(
      "-q ablate " + (d / "scene.yaml").string() + " --solvers ccfr --threads 1 --no-plot --out " + (d / "q").string(),
      d);
  ASSERT_EQ(q.code, 0) << q.out << q.err;
  EXPECT_EQ(q.err, "");
  EXPECT_TRUE(has(q.out, "ablate: 1 solvers, 3 frames in ")) << q.out;
}

TEST(SweepProgress, SweepAggregatesItsCellsAndStatusSumsTheirFrames) {
  const fs::path d = scene_dir("sweep");
  // No `frames:` in the spec: the cells run the scene's own 3 frames, which the progress reads.
  std::ofstream(d / "s.yaml") << "configs: [" << (d / "scene.yaml").string()
                              << "]\nsolvers: [ccfr, post_process, none]\nset: {contact.on_violation: warn}\n";
  const fs::path out = d / "sw";
  auto r = run_ccfr_split("sweep " + (d / "s.yaml").string() + " --out " + out.string() + " --jobs 2 --threads 1", d);
  ASSERT_EQ(r.code, 0) << r.out << r.err;
  EXPECT_TRUE(std::regex_search(r.err, std::regex(R"(sweep frames 9/9: elapsed [^,;]+; 3/3 cells done\n)"))) << r.err;
  expect_only_log_lines(r.err);
  expect_monotonic(r.err, "sweep", 9);
  EXPECT_TRUE(std::regex_search(
      r.out, std::regex("^sweep: 3 cells run, 0 failed, in [^(]+\\(9 frames in all\\); next: ccfr sweep collect " +
                        out.string() + "\n$")))
      << r.out;

  // status: frames per cell and over the sweep, also for a cell that is gone.
  const std::string lost = "scene__post_process";
  fs::remove_all(out / lost);
  r = run_ccfr_split("sweep status " + out.string(), d);
  ASSERT_EQ(r.code, 0) << r.out << r.err;
  EXPECT_TRUE(std::regex_search(r.out, std::regex("scene__ccfr +completed +3/3\n"))) << r.out;
  EXPECT_TRUE(std::regex_search(r.out, std::regex(lost + " +not started +0/3\n"))) << r.out;
  EXPECT_TRUE(has(r.out, "3 cells: 2 completed, 1 not started\nframes: 6 of 9 (67 %)\n")) << r.out;

  // resume runs the lost cell: its progress counts its 3 frames only.
  r = run_ccfr_split("sweep resume " + out.string(), d);
  ASSERT_EQ(r.code, 0) << r.out << r.err;
  EXPECT_TRUE(std::regex_search(r.err, std::regex(R"(sweep frames 3/3: elapsed [^,;]+; 1/1 cells done\n)"))) << r.err;
  EXPECT_TRUE(has(r.out, "sweep: 1 cells run, 0 failed, in ")) << r.out;
  r = run_ccfr_split("sweep status " + out.string(), d);
  EXPECT_TRUE(has(r.out, "3 cells: 3 completed\nframes: 9 of 9 (100 %)\n")) << r.out;

  // --quiet: no progress and no logs; the summary stays.
  r = run_ccfr_split("sweep " + (d / "s.yaml").string() + " --out " + (d / "q").string() + " --jobs 2 --threads 1 -q",
                     d);
  ASSERT_EQ(r.code, 0) << r.out << r.err;
  EXPECT_EQ(r.err, "");
  EXPECT_TRUE(has(r.out, "sweep: 3 cells run, 0 failed")) << r.out;
}

TEST(SweepProgress, StatusWarnsAndResumeRefusesWhenSqueueFails) {
  const fs::path d = scene_dir("squeue");
  std::ofstream(d / "s.yaml") << "configs: [" << (d / "scene.yaml").string() << "]\nsolvers: [ccfr]\n";
  const fs::path out = d / "sw";
  ASSERT_EQ(run_ccfr_split("sweep " + (d / "s.yaml").string() + " --out " + out.string() + " -q", d).code, 0);
  // As if it had been submitted to Slurm, then asked about where squeue cannot reach the cluster.
  std::string json = ccfr::test::read_text(out / "sweep.json");
  const std::string key = "\"slurm_jobs\": []";
  ASSERT_NE(json.find(key), std::string::npos) << json;
  json.replace(json.find(key), key.size(), R"("slurm_jobs": [{"job_id": "7", "array": "0"}])");
  std::ofstream(out / "sweep.json") << json;
  fs::create_directories(d / "bin");
  for (const char* tool : {"squeue", "sacct"}) {
    std::ofstream(d / "bin" / tool) << "#!/bin/sh\necho \"" << tool
                                    << ": error: unable to contact the controller\"\nexit 1\n";
    fs::permissions(d / "bin" / tool, fs::perms::owner_all);
  }
  const std::string env = "PATH=" + (d / "bin").string() + ":$PATH";
  auto r = run_ccfr_split("sweep status " + out.string(), d, env);
  EXPECT_EQ(r.code, 0) << r.out << r.err;
  EXPECT_TRUE(has(r.err, "squeue failed (exit 1): squeue: error: unable to contact the controller")) << r.err;
  EXPECT_TRUE(has(r.out, "1 cells: 1 completed\nframes: 3 of 3 (100 %)\n")) << r.out;
  // Its one cell completed: nothing is left that could run twice (issue 35: this exited 2). With a
  // cell left, resume refuses naming SLURM_CONF (Sweep.SlurmStatusShowsFramesAndResumeWithoutSlurmConf).
  r = run_ccfr_split("sweep resume " + out.string(), d, env);
  EXPECT_EQ(r.code, 0) << r.out << r.err;
  EXPECT_TRUE(has(r.out, "nothing to resume")) << r.out;
  fs::remove_all(out / "scene__ccfr");
  r = run_ccfr_split("sweep resume " + out.string(), d, env);
  EXPECT_EQ(r.code, 2) << r.out << r.err;
  EXPECT_TRUE(has(r.err, "squeue failed (above), so whether they are queued or running is unknown")) << r.err;
  EXPECT_TRUE(has(r.err, "Resuming now could run them twice")) << r.err;
  EXPECT_FALSE(fs::exists(out / "scene__ccfr")) << "resume ran the cell";
}
