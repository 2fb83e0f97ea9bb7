// `ccfr export` keeps what it cannot rebuild: it never replaces the files a run wrote itself,
// never writes into another run's folder, waits for no writer (it takes the run folder's lock)
// and refuses a run with a missing frame as the audit does. Runs the real binary.
#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include "ccfr/io/dir_lock.hpp"
#include "cli_support.hpp"

namespace fs = std::filesystem;
using ccfr::test::read_text;
using ccfr::test::run_ccfr;

namespace {

// A finished 3-frame run that wrote OBJ and VTU frames itself (with the distance, half_spaces
// and halted arrays export cannot rebuild).
fs::path vtu_run(const fs::path& root, const std::string& name) {
  const fs::path scene = ccfr::test::write_text(
      root, name + ".yaml",
      "time: {frames: 3, substeps: 2}\noutput: {formats: [obj, vtu]}\nobjects:\n"
      "  - {name: sheet, kind: cloth, shape: {type: grid, size: [0.1, 0.1], resolution: [2, 2]}}\n");
  const fs::path dir = root / name;
  const auto r = run_ccfr("run '" + scene.string() + "' --out '" + dir.string() + "' -q");
  EXPECT_EQ(r.code, 0) << r.out;
  return dir;
}

}  // namespace

TEST(Export, NeverReplacesFormatsTheRunWroteItself) {
  const fs::path root = ccfr::test::scratch_dir("export_own_formats");
  const fs::path a = vtu_run(root, "a");
  const std::string vtu = read_text(a / "vtk" / "frame_00001.vtu");
  ASSERT_NE(vtu.find("half_spaces"), std::string::npos);
  const auto r = run_ccfr("export '" + a.string() + "' --format vtu,pc2");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("wrote vtu itself"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("--out"), std::string::npos) << r.out;
  EXPECT_EQ(read_text(a / "vtk" / "frame_00001.vtu"), vtu);
  // A format the run did not write goes beside its own.
  const auto pc2 = run_ccfr("export '" + a.string() + "' --format pc2");
  EXPECT_EQ(pc2.code, 0) << pc2.out;
  EXPECT_EQ(read_text(a / "vtk" / "frame_00001.vtu"), vtu);
}

TEST(Export, NeverWritesIntoAnotherRunsFolder) {
  const fs::path root = ccfr::test::scratch_dir("export_other_run");
  const fs::path a = vtu_run(root, "a"), b = vtu_run(root, "b");
  const std::string vtu = read_text(b / "vtk" / "frame_00001.vtu");
  const auto r = run_ccfr("export '" + a.string() + "' --format vtu --out '" + b.string() + "'");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("another run's folder"), std::string::npos) << r.out;
  EXPECT_EQ(read_text(b / "vtk" / "frame_00001.vtu"), vtu);
  // A folder of its own is fine, also a second time.
  for (int i = 0; i < 2; ++i) {
    const auto ok = run_ccfr("export '" + a.string() + "' --format vtu --out '" + (root / "exported").string() + "'");
    EXPECT_EQ(ok.code, 0) << ok.out;
  }
}

TEST(Export, TakesTheRunFoldersLock) {
  const fs::path root = ccfr::test::scratch_dir("export_lock");
  const fs::path a = vtu_run(root, "a");
  const ccfr::io::DirLock held = ccfr::io::DirLock::acquire(a, "ccfr run (the test)");
  const auto r = run_ccfr("export '" + a.string() + "' --format pc2 --out '" + (root / "x").string() + "'");
  EXPECT_NE(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("ccfr run (the test)"), std::string::npos) << r.out;
  EXPECT_FALSE(fs::exists(root / "x")) << r.out;
}

TEST(Export, ARunWithAMissingFrameIsRefusedAsTheAuditRefusesIt) {
  const fs::path root = ccfr::test::scratch_dir("export_gap");
  const fs::path a = vtu_run(root, "a");
  fs::remove(a / "frames" / "frame_00002.obj");
  const auto r = run_ccfr("export '" + a.string() + "' --format pc2 --out '" + (root / "x").string() + "'");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("has a gap: 1 frame is missing"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("(2)"), std::string::npos) << r.out;
  EXPECT_FALSE(fs::exists(root / "x")) << r.out;
}
