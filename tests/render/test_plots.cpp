// Runs scripts/plot_stats.py and scripts/plot_ablation.py (Debian's /usr/bin/python3 with
// python3-matplotlib) on crafted CSVs: full runs, runs cut short, missing optional columns.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

#include "ccfr/render/image.hpp"
#include "test_support.hpp"

namespace fs = std::filesystem;

namespace {

const char* kPython = "/usr/bin/python3";

bool have_matplotlib() {
  static const bool ok = std::system((std::string(kPython) + " -c 'import matplotlib' >/dev/null 2>&1").c_str()) == 0;
  return ok;
}

/// Runs a script with arguments; returns its exit code.
int run_script(const std::string& script, const std::string& args) {
  const std::string cmd =
      std::string(kPython) + " '" + CCFR_SOURCE_DIR + "/scripts/" + script + "' " + args + " >/dev/null 2>&1";
  const int status = std::system(cmd.c_str());
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

class PlotTest : public ::testing::Test {
 protected:
  void SetUp() override {
    if (!have_matplotlib()) GTEST_SKIP() << "python3-matplotlib is not installed";
    dir_ = fs::temp_directory_path() /
           ("ccfr_plots_" + std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()) + "_" +
            std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override {
    std::error_code ec;
    fs::remove_all(dir_, ec);
  }
  fs::path write(const std::string& name, const std::string& text) {
    const fs::path p = dir_ / name;
    fs::create_directories(p.parent_path());
    std::ofstream(p) << text;
    return p;
  }
  /// The PNG exists and is a real picture.
  static void expect_png(const fs::path& p) {
    ASSERT_TRUE(fs::exists(p)) << p;
    const ccfr::render::Image img = ccfr::render::read_png(p);
    EXPECT_GT(img.width, 200);
    EXPECT_GT(img.height, 200);
  }
  fs::path dir_;
};

const std::string kStatsHeader =
    "frame,sim_time,wall_s,xpbd_s,broad_s,narrow_s,resolution_s,candidates,constraints,violations_detected,"
    "violations_remaining,halted_vertices,min_distance,penetrations,audit_s,outer_iterations,clamped_vertices\n";

}  // namespace

TEST_F(PlotTest, StatsFullRun) {
  std::string csv = kStatsHeader;
  for (int f = 0; f < 30; ++f)
    csv += std::to_string(f) + "," + std::to_string(f / 30.0) + ",0.05,0.02,0.01,0.012,0.006,1000,200," +
           std::to_string(40 + f) + "," + std::to_string(f % 3) + "," + std::to_string(f % 2) +
           (f == 0 ? ",," : ",0.0011,0,") + "0.0,3,0\n";
  write("run/stats.csv", csv);
  EXPECT_EQ(run_script("plot_stats.py", "'" + (dir_ / "run").string() + "'"), 0);
  expect_png(dir_ / "run/stats.png");
}

TEST_F(PlotTest, StatsRunsCutShort) {
  // Header only (the run died before its first frame).
  write("empty/stats.csv", kStatsHeader);
  EXPECT_EQ(run_script("plot_stats.py", "'" + (dir_ / "empty").string() + "'"), 0);
  expect_png(dir_ / "empty/stats.png");
  // One row, and a last row truncated mid-line by a crash.
  write("one/stats.csv", kStatsHeader + "0,0,0.01,0,0,0,0,0,0,0,0,0,,,0,0,0\n");
  EXPECT_EQ(run_script("plot_stats.py",
                       "'" + (dir_ / "one/stats.csv").string() + "' --out '" + (dir_ / "one.png").string() + "'"),
            0);
  expect_png(dir_ / "one.png");
  write("cut/stats.csv", kStatsHeader + "0,0,0.01,0.005,0.001,0.001,0.001,5,5,1,0,0,0.002,0,0,1,0\n1,0.03,0.0");
  EXPECT_EQ(run_script("plot_stats.py", "'" + (dir_ / "cut").string() + "'"), 0);
  expect_png(dir_ / "cut/stats.png");
  // A completely empty file.
  write("blank/stats.csv", "");
  EXPECT_EQ(run_script("plot_stats.py", "'" + (dir_ / "blank").string() + "'"), 0);
}

TEST_F(PlotTest, StatsMissingOptionalColumns) {
  // An older or minimal writer: only a few columns, one of them with NaN and inf.
  write("old/stats.csv", "frame,wall_s,xpbd_s,violations_detected\n0,0.1,0.05,3\n1,nan,0.04,inf\n2,0.1,0.05,1\n");
  EXPECT_EQ(run_script("plot_stats.py", "'" + (dir_ / "old").string() + "' --title minimal"), 0);
  expect_png(dir_ / "old/stats.png");
}

TEST_F(PlotTest, StatsRejectsMissingInput) {
  EXPECT_EQ(run_script("plot_stats.py", "'" + (dir_ / "nowhere").string() + "'"), 2);
}

TEST_F(PlotTest, Ablation) {
  write("abl/ablation.csv",
        "solver,avg_frame_s,max_frame_s,xpbd_s,broad_s,narrow_s,resolution_s,violations_detected,"
        "violations_remaining,halted_vertices,audit,min_distance_over_offset\n"
        "ccfr,0.05,0.09,0.02,0.01,0.01,0.005,1200,0,3,pass,1.0\n"
        "successive_projection,0.07,0.12,0.02,0.01,0.01,0.025,1300,12,40,pass,0.98\n"
        "post_process,0.04,0.06,0.02,0.01,0.01,0.001,1500,300,0,fail,0.2\n");
  EXPECT_EQ(run_script("plot_ablation.py", "'" + (dir_ / "abl").string() + "'"), 0);
  expect_png(dir_ / "abl/ablation.png");
  // Header only, and a table missing most columns with empty cells.
  write("abl0/ablation.csv", "solver,avg_frame_s,max_frame_s\n");
  EXPECT_EQ(run_script("plot_ablation.py", "'" + (dir_ / "abl0").string() + "'"), 0);
  expect_png(dir_ / "abl0/ablation.png");
  write("abl1/ablation.csv", "solver,avg_frame_s,audit\nccfr,0.05,\nnone,,0\n");
  EXPECT_EQ(run_script("plot_ablation.py", "'" + (dir_ / "abl1").string() + "'"), 0);
  expect_png(dir_ / "abl1/ablation.png");
  EXPECT_EQ(run_script("plot_ablation.py", "'" + (dir_ / "missing").string() + "'"), 2);
}
