// An output format registered from outside ccfr (docs/extending.md, "An output format") is selected
// by `output.formats`, takes its parameters from `output.<key>` and writes its files into the run
// like a built-in. In the apps suite: the registration stays for the rest of the process, and the
// io suite compares the registry with the built-in files and docs/config.md.
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "ccfr/io/formats.hpp"
#include "ccfr/io/obj.hpp"
#include "ccfr/io/output.hpp"
#include "ccfr/io/run_recorder.hpp"
#include "ccfr/io/scene_loader.hpp"
#include "ccfr/solvers/simulation.hpp"
#include "cli_support.hpp"
#include "config_support.hpp"

namespace fs = std::filesystem;
using namespace ccfr;

namespace {

/// csv_positions/frame_N.csv: one line "x,y,z" per vertex, with `digits` significant digits.
class CsvPositions final : public io::FrameSink {
 public:
  explicit CsvPositions(int digits) : digits_(digits) {}
  void write(const fs::path& dir, int frame, double, const Positions& x, const io::VertexFields&) override {
    fs::create_directories(dir / "csv_positions");
    std::ofstream out(dir / "csv_positions" / ("frame_" + std::to_string(frame) + ".csv"));
    for (const Vec3& p : x) out << line(p, digits_);
  }
  static std::string line(const Vec3& p, int digits) {
    char buf[128];
    std::snprintf(buf, sizeof buf, "%.*g,%.*g,%.*g\n", digits, p.x(), digits, p.y(), digits, p.z());
    return buf;
  }

 private:
  int digits_;
};

void register_csv_positions() {
  static const bool once = [] {
    io::frame_writers().add({"csv_positions",
                             "csv_positions/frame_N.csv, one line x,y,z per vertex",
                             {ParamSpec::integer("digits", 17, "significant digits", 1, 17)},
                             [](const ParamValues& p, const io::FrameSinkContext&) {
                               return std::make_unique<CsvPositions>(static_cast<int>(p.integer("digits")));
                             }});
    return true;
  }();
  (void)once;
}

const char* kScene = R"(scene: csv
time: {fps: 60, frames: 2}
objects:
  - name: sheet
    kind: cloth
    shape: {type: grid, size: [1, 1], resolution: [3, 3]}
)";

std::string read_text(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

/// Runs kScene with `output` as its output section into a fresh scratch directory.
fs::path run_scene(const std::string& name, const std::string& output) {
  io::LoadedScene loaded = io::load_scene_text(std::string(kScene) + output, "csv.yaml", ".");
  Simulation sim(std::move(loaded.scene));
  const fs::path dir = test::scratch_dir(name);
  io::RunRecorder rec(dir, sim, loaded.resolved_json, io::make_run_meta(sim, "test", {}), 2);
  rec.start();
  for (int f = 1; f <= 2; ++f) rec.record(sim.step_frame());
  rec.finish("completed");
  return dir;
}

}  // namespace

TEST(FrameWriters, OneRegisteredOutsideIsSelectedByOutputFormatsAndWritesItsFiles) {
  register_csv_positions();
  const fs::path dir = run_scene("frame_writer_csv", "output: {formats: [obj, csv_positions]}\n");
  // Every frame, against the exact positions of the built-in OBJ frames of the same run.
  for (int frame = 0; frame <= 2; ++frame) {
    char obj[32];
    std::snprintf(obj, sizeof obj, "frame_%05d.obj", frame);
    const Positions x = io::read_frame_obj(dir / "frames" / obj).v;
    ASSERT_EQ(x.size(), 16u);  // a 4 x 4 grid
    std::string expected;
    for (const Vec3& p : x) expected += CsvPositions::line(p, 17);
    EXPECT_EQ(read_text(dir / "csv_positions" / ("frame_" + std::to_string(frame) + ".csv")), expected) << frame;
  }
  // The cloth fell: the frames are not all the first one.
  EXPECT_NE(read_text(dir / "csv_positions" / "frame_0.csv"), read_text(dir / "csv_positions" / "frame_2.csv"));
  // Its folder is the run's own (moved and replaced by a rerun), and the schema's docs list it.
  EXPECT_TRUE(io::is_run_entry("csv_positions"));
  const std::string ref = io::config_reference_markdown();
  EXPECT_NE(ref.find("| `csv_positions` | `output.csv_positions.digits` |"), std::string::npos);
  EXPECT_NE(ref.find("`output.csv_positions.digits`"), std::string::npos);
}

TEST(FrameWriters, AWritersParametersComeFromItsOwnSection) {
  register_csv_positions();
  const fs::path dir =
      run_scene("frame_writer_csv_digits", "output: {formats: [obj, csv_positions], csv_positions: {digits: 3}}\n");
  const Positions x = io::read_frame_obj(dir / "frames" / "frame_00002.obj").v;
  std::string expected, exact;
  for (const Vec3& p : x) expected += CsvPositions::line(p, 3), exact += CsvPositions::line(p, 17);
  EXPECT_EQ(read_text(dir / "csv_positions" / "frame_2.csv"), expected);
  ASSERT_NE(expected, exact);  // the default would be told apart
}

TEST(FrameWriters, BadUseOfAWriterIsAnErrorNamingTheKey) {
  register_csv_positions();
  const auto range =
      test::config_error(std::string(kScene) + "output: {formats: [csv_positions], csv_positions: {digits: 0}}\n");
  EXPECT_EQ(range.key_path(), "output.csv_positions.digits");
  // A section for a format the run does not write.
  const auto unused = test::config_error(std::string(kScene) + "output: {csv_positions: {digits: 5}}\n");
  EXPECT_EQ(unused.key_path(), "output.csv_positions");
  EXPECT_NE(std::string(unused.what()).find("output.formats does not list it"), std::string::npos) << unused.what();
  const auto unknown = test::config_error(std::string(kScene) + "output: {formats: [csv_position]}\n");
  EXPECT_EQ(unknown.key_path(), "output.formats[0]");
  EXPECT_NE(std::string(unknown.what()).find("csv_positions"), std::string::npos) << unknown.what();
}
