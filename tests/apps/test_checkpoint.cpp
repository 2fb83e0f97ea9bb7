// Checkpoints and `ccfr run --resume`: a run killed mid-way and resumed writes the same frames and
// stats (timing columns aside) as one that was never interrupted; damaged or mismatched
// checkpoints are refused naming the file and what does not fit. Runs the real binary.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "ccfr/core/error.hpp"
#include "ccfr/io/checkpoint.hpp"
#include "cli_support.hpp"

namespace fs = std::filesystem;
using ccfr::test::run_ccfr;

namespace {

std::string read(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

void write(const fs::path& p, const std::string& s) {
  std::ofstream out(p, std::ios::binary | std::ios::trunc);
  out << s;
}

std::string config(const std::string& name) { return std::string(CCFR_SOURCE_DIR) + "/configs/" + name; }

/// stats.csv without the timing columns (wall_s, cpu_s, the stages' seconds and their serial parts), which are the only
/// ones allowed to differ between two runs of one scene.
std::string stats_without_timing(const fs::path& csv) {
  std::istringstream in(read(csv));
  std::string out, line;
  const std::vector<std::string> timing{"wall_s",
                                        "cpu_s",
                                        "xpbd_s",
                                        "broad_s",
                                        "narrow_s",
                                        "audit_s",
                                        "check_s",
                                        "resolution_s",
                                        "serial_s",
                                        "xpbd_serial_s",
                                        "broad_serial_s",
                                        "narrow_serial_s",
                                        "resolution_serial_s",
                                        "check_serial_s"};
  std::vector<bool> keep;
  while (std::getline(in, line)) {
    std::vector<std::string> cells;
    std::stringstream ls(line);
    for (std::string c; std::getline(ls, c, ',');) cells.push_back(c);
    if (line.back() == ',') cells.emplace_back();
    if (keep.empty())
      for (const auto& c : cells) keep.push_back(std::find(timing.begin(), timing.end(), c) == timing.end());
    EXPECT_EQ(cells.size(), keep.size()) << line;
    for (size_t i = 0; i < cells.size() && i < keep.size(); ++i)
      if (keep[i]) out += cells[i] + ",";
    out += "\n";
  }
  return out;
}

/// Runs `args` and sends `sig` as soon as the checkpoint of frame `at` exists; fails the test if
/// the run ended before that. Returns the exit status.
int run_and_interrupt(const std::vector<std::string>& args, const fs::path& dir, int at, int sig, const fs::path& log) {
  const pid_t pid = ccfr::test::spawn_ccfr(args, log);
  const fs::path ckpt = ccfr::io::checkpoint_path(dir, at);
  int status = 0;
  for (;;) {
    if (fs::exists(ckpt)) {
      ::kill(pid, sig);
      break;
    }
    if (::waitpid(pid, &status, WNOHANG) == pid) {
      ADD_FAILURE() << "the run ended before its checkpoint of frame " << at << " appeared:\n" << read(log);
      return status;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  ::waitpid(pid, &status, 0);
  return status;
}

/// Frames of two run directories, byte for byte.
void expect_same_frames(const fs::path& a, const fs::path& b) {
  std::vector<std::string> names;
  for (const auto& e : fs::directory_iterator(a / "frames")) names.push_back(e.path().filename().string());
  size_t nb = 0;
  for (const auto& e : fs::directory_iterator(b / "frames")) nb += e.path().extension() == ".obj";
  ASSERT_FALSE(names.empty());
  EXPECT_EQ(names.size(), nb);
  for (const auto& n : names) EXPECT_TRUE(read(a / "frames" / n) == read(b / "frames" / n)) << n << " differs";
}

struct Case {
  const char* name;
  const char* scene;
  std::vector<std::string> sets;  // --set overrides of both runs
  int frames, checkpoint_every, kill_at, signal;
};

void check_resume_is_identical(const Case& c) {
  const fs::path root = ccfr::test::scratch_dir("checkpoint_" + std::string(c.name));
  std::vector<std::string> args{
      "run",         config(c.scene), "--frames", std::to_string(c.frames),
      "--log-level", "warn",          "--set",    "output.checkpoint_every=" + std::to_string(c.checkpoint_every)};
  for (const auto& s : c.sets) args.insert(args.end(), {"--set", s});
  auto with_out = [&](const fs::path& out) {
    auto a = args;
    a.insert(a.end(), {"--out", out.string()});
    return a;
  };
  const fs::path ref = root / "uninterrupted", cut = root / "resumed";
  std::string ref_cmd;
  for (const auto& a : with_out(ref)) ref_cmd += "'" + a + "' ";
  const auto r = run_ccfr(ref_cmd);
  ASSERT_TRUE(r.code == 0 || r.code == 3) << r.out;

  const int status = run_and_interrupt(with_out(cut), cut, c.kill_at, c.signal, root / "cut.log");
  if (c.signal == SIGKILL) {
    ASSERT_TRUE(WIFSIGNALED(status)) << read(root / "cut.log");
  } else {
    ASSERT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 1) << read(root / "cut.log");
    EXPECT_NE(read(cut / "run.json").find("terminated after frame"), std::string::npos);
  }
  const auto latest = ccfr::io::latest_checkpoint(cut);
  ASSERT_TRUE(latest.has_value());
  const int at = ccfr::io::read_checkpoint(*latest).sim.frame;
  ASSERT_GE(at, c.kill_at);
  ASSERT_LT(at, c.frames) << "the run finished before it was interrupted; the test proves nothing";

  // A different thread count: runs are deterministic across thread counts.
  const auto res = run_ccfr("run --resume '" + cut.string() + "' --threads 1 --log-level warn");
  ASSERT_TRUE(res.code == r.code) << res.out;
  EXPECT_NE(res.out.find("resumed after frame " + std::to_string(at)), std::string::npos) << res.out;
  expect_same_frames(ref, cut);
  EXPECT_EQ(stats_without_timing(ref / "stats.csv"), stats_without_timing(cut / "stats.csv"));
  const auto rj = nlohmann::json::parse(read(cut / "run.json"));
  EXPECT_EQ(rj["status"], "completed");
  EXPECT_EQ(rj["frames_written"], c.frames + 1);
  ASSERT_TRUE(rj.contains("resumed"));
  EXPECT_EQ(rj["resumed"][0]["after_frame"], at);

  // Resuming a completed run is a no-op.
  const auto again = run_ccfr("run --resume '" + cut.string() + "'");
  EXPECT_EQ(again.code, 0) << again.out;
  EXPECT_NE(again.out.find("nothing to resume"), std::string::npos) << again.out;
}

}  // namespace

TEST(Checkpoint, Crc32MatchesTheStandardCheckValue) {
  // The CRC-32 check value of "123456789" (IEEE 802.3 / zlib), and of the empty string.
  EXPECT_EQ(ccfr::io::crc32("123456789"), 0xCBF43926u);
  EXPECT_EQ(ccfr::io::crc32(""), 0u);
}

TEST(Checkpoint, EncodeDecodeRoundTrips) {
  ccfr::io::Checkpoint c;
  c.sim.frame = 7;
  c.sim.time = 0.25;
  c.sim.x = {ccfr::Vec3(1, 2, 3), ccfr::Vec3(-0.0, 1e-300, 4)};
  c.sim.v = {ccfr::Vec3(0.5, 0, 0), ccfr::Vec3(0, 0, -9.81)};
  c.sim.x_prev = c.sim.x;
  c.sim.solver_state = {0.001, 0.002};
  c.sim.warned_capped = {0, 1};
  c.resolved_config = R"({"a": 1})";
  c.scene_file = "/x/y.yaml";
  c.overrides = {"time.frames=3", ""};
  c.audit_offsets = {0.5};
  c.violated_frames = 2;
  c.frames_written = 8;
  const auto d = ccfr::io::decode_checkpoint(ccfr::io::encode_checkpoint(c), "mem");
  EXPECT_EQ(d.sim.frame, 7);
  EXPECT_EQ(d.sim.x, c.sim.x);
  EXPECT_EQ(d.sim.v, c.sim.v);
  EXPECT_EQ(d.sim.solver_state, c.sim.solver_state);
  EXPECT_EQ(d.sim.warned_capped, c.sim.warned_capped);
  EXPECT_EQ(d.overrides, c.overrides);
  EXPECT_EQ(d.audit_offsets, c.audit_offsets);
  EXPECT_EQ(d.frames_written, 8);
  // Degenerate: nothing at all, and a checkpoint of an empty scene.
  EXPECT_THROW(ccfr::io::decode_checkpoint("", "empty"), ccfr::Error);
  const auto e = ccfr::io::decode_checkpoint(ccfr::io::encode_checkpoint(ccfr::io::Checkpoint{}), "mem");
  EXPECT_TRUE(e.sim.x.empty());
}

TEST(Checkpoint, JsonDifferenceNamesTheKeyPath) {
  EXPECT_EQ(ccfr::io::json_difference(R"({"a":{"b":1}})", R"({"a":{"b":1}})"), "");
  EXPECT_EQ(ccfr::io::json_difference(R"({"a":{"b":1,"c":[1,2]}})", R"({"a":{"b":1,"c":[1,3]}})"),
            "a.c[1]: 2 in the checkpoint, 3 now");
}

// Pairs that start closer than ξ (reduced offsets: the detector's state) and the in-simulation audit
// (its own reduced offsets), killed with SIGKILL between checkpoints.
TEST(Checkpoint, SigkillThenResumeIsIdenticalWithReducedOffsetsAndAudit) {
  check_resume_is_identical({"near", "stress/sheets_near.yaml", {"debug.audit=every_frame"}, 16, 3, 6, SIGKILL});
}

// A rigid body on cloth under a baseline solver; SIGTERM (scancel, a job's time limit) writes a
// checkpoint of the frame it stopped after.
TEST(Checkpoint, SigtermThenResumeIsIdenticalWithRigidBodiesAndABaseline) {
  check_resume_is_identical(
      {"cube", "cube_on_cloth.yaml", {"contact.solver=post_process", "contact.on_violation=warn"}, 14, 4, 4, SIGTERM});
}

TEST(Checkpoint, DamagedOrMismatchedCheckpointsAreRefused) {
  const fs::path root = ccfr::test::scratch_dir("checkpoint_refusals");
  const fs::path scene = root / "scene.yaml";
  write(scene, read(config("two_sheets.yaml")));
  const fs::path dir = root / "run";
  const auto r = run_ccfr("run '" + scene.string() + "' --frames 5 --set output.checkpoint_every=2 --out '" +
                          dir.string() + "' --log-level warn");
  ASSERT_EQ(r.code, 0) << r.out;
  // Pretend the run was cut short after its checkpoint of frame 4.
  auto j = nlohmann::json::parse(read(dir / "run.json"));
  j["status"] = "running";
  write(dir / "run.json", j.dump());
  const fs::path ck = ccfr::io::checkpoint_path(dir, 4);
  ASSERT_TRUE(fs::exists(ck));
  EXPECT_FALSE(fs::exists(ccfr::io::checkpoint_path(dir, 2))) << "older checkpoints are removed";
  const std::string good = read(ck), frames_before = read(dir / "frames" / "frame_00005.obj");
  const std::string resume = "run --resume '" + dir.string() + "'";

  auto refused = [&](const std::string& bytes, const std::string& why) {
    write(ck, bytes);
    const auto res = run_ccfr(resume);
    EXPECT_EQ(res.code, 2) << res.out;
    EXPECT_NE(res.out.find(ck.string()), std::string::npos) << res.out;
    EXPECT_NE(res.out.find(why), std::string::npos) << res.out;
    EXPECT_EQ(read(dir / "frames" / "frame_00005.obj"), frames_before) << "a refused resume changes nothing";
  };
  std::string flipped = good;
  flipped[flipped.size() / 2] ^= 0x10;
  refused(flipped, "is corrupted: checksum mismatch");
  refused(good.substr(0, good.size() - 9), "is truncated");
  refused(good.substr(0, 12), "is truncated");
  refused(good + "x", "trailing bytes");
  std::string other_format = good;
  other_format[8] = 2;
  refused(other_format, "format version 2");
  refused("not a checkpoint at all", "is not a ccfr checkpoint");

  // The scene changed since: the first differing key is named.
  write(ck, good);
  std::string text = read(scene);
  const size_t at = text.find("fps: 60");
  ASSERT_NE(at, std::string::npos);
  write(scene, text.substr(0, at) + "fps: 61" + text.substr(at + 7));
  auto res = run_ccfr(resume);
  EXPECT_EQ(res.code, 2) << res.out;
  EXPECT_NE(res.out.find("does not match its scene"), std::string::npos) << res.out;
  EXPECT_NE(res.out.find("time.fps: 60 in the checkpoint, 61 now"), std::string::npos) << res.out;
  write(scene, text);

  // Options that would change the run, and a directory without a checkpoint.
  res = run_ccfr(resume + " --set contact.offset=0.02");
  EXPECT_EQ(res.code, 2) << res.out;
  EXPECT_NE(res.out.find("--resume continues a run exactly as it was configured"), std::string::npos) << res.out;
  fs::remove(ck);
  res = run_ccfr(resume);
  EXPECT_EQ(res.code, 2) << res.out;
  EXPECT_NE(res.out.find("no checkpoint in"), std::string::npos) << res.out;

  // With the checkpoint back, the resume works and completes the run.
  write(ck, good);
  res = run_ccfr(resume + " --log-level warn");
  EXPECT_EQ(res.code, 0) << res.out;
  EXPECT_EQ(read(dir / "frames" / "frame_00005.obj"), frames_before);
}

// FCL's tree is rebalanced as it goes, so a resumed run's fresh tree traverses in another order;
// the broad phase reports its pairs sorted, and the contacts come out the same.
TEST(Checkpoint, ResumeIsIdenticalUnderTheFclBroadPhase) {
  check_resume_is_identical({"fcl", "two_sheets.yaml", {"collision.broad_phase=fcl"}, 16, 4, 8, SIGKILL});
}

// A checkpoint is resumed only in the run that wrote it, and only after every frame before it:
// a checkpoint copied from another scene's run matches its own scene and used to be accepted (the
// frames after it were then the other scene's), and a frame deleted before the resume left a gap
// that the finished run and its audit did not show.
TEST(Checkpoint, ResumeRefusesAForeignCheckpointAndMissingFrames) {
  const fs::path root = ccfr::test::scratch_dir("checkpoint_belongs");
  const fs::path scene_a = root / "a.yaml", scene_b = root / "b.yaml";
  const std::string text = read(config("two_sheets.yaml"));
  write(scene_a, text);
  const size_t at = text.find("resolution: [26, 26]");
  ASSERT_NE(at, std::string::npos);
  write(scene_b, text.substr(0, at) + "resolution: [20, 20]" + text.substr(at + 20));  // another vertex count
  const fs::path a = root / "a", b = root / "b";
  for (const auto& [scene, dir] : {std::pair{scene_a, a}, std::pair{scene_b, b}}) {
    const auto r = run_ccfr("run '" + scene.string() + "' --frames 5 --set output.checkpoint_every=2 --out '" +
                            dir.string() + "' --log-level warn");
    ASSERT_EQ(r.code, 0) << r.out;
  }
  auto rj = nlohmann::json::parse(read(a / "run.json"));
  ASSERT_TRUE(rj.contains("scene_fingerprint")) << rj.dump();
  EXPECT_EQ(rj["scene_fingerprint"].get<std::string>().size(), 16u);
  rj["status"] = "running";  // pretend it was cut short after its checkpoint of frame 4
  write(a / "run.json", rj.dump());
  const fs::path ck = ccfr::io::checkpoint_path(a, 4);
  const std::string own = read(ck), frame5 = read(a / "frames" / "frame_00005.obj");
  const std::string resume = "run --resume '" + a.string() + "' --log-level warn";

  // B's checkpoint copied into A: another fingerprint than A's run.json records.
  write(ck, read(ccfr::io::checkpoint_path(b, 4)));
  auto r = run_ccfr(resume);
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("does not belong to the run in '" + a.string() + "'"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("its scene fingerprint is"), std::string::npos) << r.out;
  EXPECT_EQ(read(a / "frames" / "frame_00005.obj"), frame5) << "a refused resume changes nothing";
  // A run.json without the fingerprint (an older ccfr): its config tells the runs apart.
  auto old = rj;
  old.erase("scene_fingerprint");
  write(a / "run.json", old.dump());
  r = run_ccfr(resume);
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("run.json's config and the checkpoint's differ at objects"), std::string::npos) << r.out;
  write(a / "run.json", rj.dump());
  write(ck, own);

  // A frame before the checkpoint deleted, or not a frame, or another run's frame 4.
  const fs::path f2 = a / "frames" / "frame_00002.obj", f4 = a / "frames" / "frame_00004.obj";
  const std::string frame2 = read(f2), frame4 = read(f4);
  fs::remove(f2);
  r = run_ccfr(resume);
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("1 of the frames it follows is missing from '" + (a / "frames").string() + "' (2)"),
            std::string::npos)
      << r.out;
  write(f2, "garbage\n");
  r = run_ccfr(resume);
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("'" + f2.string() + "' cannot be read as a ccfr frame"), std::string::npos) << r.out;
  write(f2, frame2);
  write(f4, read(a / "frames" / "frame_00003.obj"));
  r = run_ccfr(resume);
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("does not hold the checkpoint's positions"), std::string::npos) << r.out;
  write(f4, frame4);

  // Everything in place: the resume completes and the audit certifies the whole sequence.
  r = run_ccfr(resume);
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_EQ(read(a / "frames" / "frame_00005.obj"), frame5);
  r = run_ccfr("audit '" + a.string() + "'");
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("PASS (all 6 frames checked)"), std::string::npos) << r.out;
}

namespace {

/// Every file of a run directory by its path inside it, but for what differs between any two runs
/// of one scene: run.json (times, the resume record), checkpoints/, the lock, audit.json (a sweep
/// cell's audit, not the run's output), and stats.csv, whose timing columns are dropped.
std::map<std::string, std::string> run_files(const fs::path& dir) {
  std::map<std::string, std::string> files;
  for (const auto& e : fs::recursive_directory_iterator(dir)) {
    const std::string rel = fs::relative(e.path(), dir).string();
    if (!e.is_regular_file() || rel == "run.json" || rel == ".ccfr-lock" || rel == "audit.json" ||
        rel.rfind("checkpoints", 0) == 0)
      continue;
    files[rel] = rel == "stats.csv" ? stats_without_timing(e.path()) : read(e.path());
  }
  return files;
}

struct FormatCase {
  const char* name;
  const char* formats;  // output.formats
  int every, signal;
};

void PrintTo(const FormatCase& c, std::ostream* os) { *os << c.name << " " << c.formats; }

class ResumeFormats : public ::testing::TestWithParam<FormatCase> {};

// A run stopped after a checkpoint and resumed writes every format byte for byte as the run that
// was never stopped: per-frame files kept (those after the checkpoint removed and written again),
// PC2 caches cut back to the checkpoint and appended, the VTU collection and the USDA layer
// rebuilt with the frames before it (from the OBJ frames, else from the PC2 caches). On main the
// resume was refused for vtu, pc2 and usda (and --resume takes no --set to change the formats),
// and a resumed ply run wrote no .ply frame after its checkpoint.
TEST_P(ResumeFormats, ResumedOutputIsByteIdenticalToAnUninterruptedRun) {
  const FormatCase c = GetParam();
  const fs::path root = ccfr::test::scratch_dir("resume_formats_" + std::string(c.name));
  const int frames = 16, kill_at = 3;
  const std::vector<std::string> args{"run",         config("stress/cloth_near_floor.yaml"),
                                      "--frames",    std::to_string(frames),
                                      "--log-level", "warn",
                                      "--set",       "output.checkpoint_every=3",
                                      "--set",       std::string("output.formats=") + c.formats,
                                      "--set",       "output.every=" + std::to_string(c.every)};
  auto with_out = [&](const fs::path& out) {
    auto a = args;
    a.insert(a.end(), {"--out", out.string()});
    return a;
  };
  const fs::path ref = root / "uninterrupted", cut = fs::absolute(root / "resumed");
  std::string ref_cmd;
  for (const auto& a : with_out(ref)) ref_cmd += "'" + a + "' ";
  const auto r = run_ccfr(ref_cmd);
  ASSERT_EQ(r.code, 0) << r.out;

  const int status = run_and_interrupt(with_out(cut), cut, kill_at, c.signal, root / "cut.log");
  std::string next = "ccfr run --resume " + cut.string();
  if (c.signal == SIGKILL) {
    ASSERT_TRUE(WIFSIGNALED(status)) << read(root / "cut.log");
  } else {
    ASSERT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 1) << read(root / "cut.log");
    // The summary names the command that continues the run, not `ccfr audit` (which exits 4 on it).
    const std::string log = read(root / "cut.log");
    ASSERT_NE(log.find("  next: " + next + "\n"), std::string::npos) << log;
  }
  const int at = ccfr::io::read_checkpoint(*ccfr::io::latest_checkpoint(cut)).sim.frame;
  ASSERT_LT(at, frames) << "the run finished before it was interrupted; the test proves nothing";
  EXPECT_NE(run_files(ref), run_files(cut)) << "the interrupted run already holds the whole output";

  const auto res = run_ccfr(next.substr(5) + " --log-level warn");
  ASSERT_EQ(res.code, 0) << res.out;
  EXPECT_NE(res.out.find("resumed after frame " + std::to_string(at)), std::string::npos) << res.out;
  EXPECT_NE(res.out.find("next: ccfr audit " + cut.string()), std::string::npos) << res.out;
  const auto a = run_files(ref), b = run_files(cut);
  std::vector<std::string> names_a, names_b;
  for (const auto& [n, _] : a) names_a.push_back(n);
  for (const auto& [n, _] : b) names_b.push_back(n);
  ASSERT_EQ(names_a, names_b);
  for (const auto& [n, bytes] : a) EXPECT_TRUE(bytes == b.at(n)) << n << " differs";
  // The formats asked for are there: the comparison is not between two empty folders.
  const std::string formats = c.formats;
  for (const auto& [format, file] : std::vector<std::pair<std::string, std::string>>{{"vtu", "vtk/frames.pvd"},
                                                                                     {"pc2", "blender/manifest.json"},
                                                                                     {"usda", "usd/scene.usda"},
                                                                                     {"ply", "frames/frame_00008.ply"},
                                                                                     {"obj", "frames/frame_00008.obj"}})
    EXPECT_EQ(a.count(file), formats.find(format) != std::string::npos ? 1u : 0u) << file;
}

INSTANTIATE_TEST_SUITE_P(
    Formats, ResumeFormats,
    ::testing::Values(FormatCase{"vtu", "[obj,vtu]", 1, SIGTERM}, FormatCase{"pc2", "[obj,pc2]", 2, SIGKILL},
                      FormatCase{"usda", "[obj,usda]", 1, SIGKILL}, FormatCase{"ply", "[obj,ply]", 1, SIGKILL},
                      FormatCase{"all", "[obj,ply,vtu,pc2,usda]", 2, SIGTERM},
                      FormatCase{"pc2_usda_no_obj", "[pc2,usda]", 1, SIGTERM},
                      FormatCase{"vtu_no_obj", "[vtu]", 1, SIGKILL}, FormatCase{"usda_only", "[usda]", 1, SIGKILL}),
    [](const ::testing::TestParamInfo<FormatCase>& i) { return std::string(i.param.name); });

// A run stopped without a checkpoint to resume from (output.checkpoint_every: 0) cannot be
// resumed: its summary gives the same command again, not `ccfr audit` (exit 4 on a cut-short run).
TEST(InterruptedRun, WithoutCheckpointNamesTheSameCommandAgain) {
  const fs::path root = ccfr::test::scratch_dir("resume_formats_none");
  const fs::path cut = root / "run";
  const pid_t pid = ccfr::test::spawn_ccfr({"run", config("stress/cloth_near_floor.yaml"), "--frames", "40", "--set",
                                            "output.checkpoint_every=0", "--out", cut.string(), "--log-level", "warn"},
                                           root / "cut.log");
  int status = 0;
  while (!fs::exists(cut / "frames" / "frame_00001.obj") && ::waitpid(pid, &status, WNOHANG) != pid)
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  ::kill(pid, SIGINT);
  ::waitpid(pid, &status, 0);
  const std::string log = read(root / "cut.log");
  ASSERT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 1) << log;
  EXPECT_NE(log.find("  next: ccfr run " + config("stress/cloth_near_floor.yaml") +
                     " --frames 40 --set output.checkpoint_every=0 --out " + cut.string() +
                     " --log-level warn  (again: no checkpoint to resume from)\n"),
            std::string::npos)
      << log;
}

// USDA alone: nothing the run wrote holds the frames before the checkpoint once a SIGKILL left no
// layer, so the resume is refused, naming why, before any file changes.
TEST(InterruptedRun, UsdaAloneWithoutItsSamplesFileIsRefusedNamingIt) {
  const fs::path root = ccfr::test::scratch_dir("resume_formats_usda_only");
  const fs::path dir = root / "run";
  auto r = run_ccfr("run '" + config("stress/cloth_near_floor.yaml") +
                    "' --frames 5 --set output.checkpoint_every=2 --set 'output.formats=[usda]' --out '" +
                    dir.string() + "' --log-level warn");
  ASSERT_EQ(r.code, 0) << r.out;
  // A layer alone keeps its samples (the only copy of the frames before a checkpoint): 6 frames.
  const fs::path samples = dir / "usd" / "scene.usda.samples";
  ASSERT_TRUE(fs::exists(samples));
  const auto n = static_cast<std::uintmax_t>(nlohmann::json::parse(read(dir / "run.json"))["vertices"].get<long>());
  EXPECT_EQ(fs::file_size(samples), 12 + 6 * (4 + 12 * n));
  auto rj = nlohmann::json::parse(read(dir / "run.json"));
  rj["status"] = "running";  // as if cut short after its checkpoint of frame 4
  write(dir / "run.json", rj.dump());
  fs::remove(samples);
  const std::string layer = read(dir / "usd" / "scene.usda"), stats = read(dir / "stats.csv");
  r = run_ccfr("run --resume '" + dir.string() + "'");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("scene.usda.samples"), std::string::npos) << r.out;
  EXPECT_EQ(read(dir / "usd" / "scene.usda"), layer);
  EXPECT_EQ(read(dir / "stats.csv"), stats);
}

// A VTU frame before the checkpoint deleted: the resume is refused naming it, and nothing changes,
// not even the PLY frames after the checkpoint (the ply sink, first in the list, used to remove
// them before the vtu sink found the gap).
TEST(InterruptedRun, AMissingVtuFrameIsRefusedBeforeAnyFileChanges) {
  const fs::path root = ccfr::test::scratch_dir("resume_formats_gap");
  const fs::path dir = root / "run";
  auto r = run_ccfr("run '" + config("stress/cloth_near_floor.yaml") +
                    "' --frames 5 --set output.checkpoint_every=2 --set 'output.formats=[obj, ply, vtu, pc2]' --out '" +
                    dir.string() + "' --log-level warn");
  ASSERT_EQ(r.code, 0) << r.out;
  auto rj = nlohmann::json::parse(read(dir / "run.json"));
  rj["status"] = "running";  // as if cut short after its checkpoint of frame 4
  write(dir / "run.json", rj.dump());
  fs::remove(dir / "vtk" / "frame_00002.vtu");
  const std::string pc2 = read(dir / "blender" / "001_cloth.pc2");
  r = run_ccfr("run --resume '" + dir.string() + "'");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("'" + (dir / "vtk" / "frame_00002.vtu").string() +
                       "' (written before the checkpoint of frame 4) is missing"),
            std::string::npos)
      << r.out;
  EXPECT_TRUE(fs::exists(dir / "frames" / "frame_00005.ply"));
  EXPECT_TRUE(fs::exists(dir / "frames" / "frame_00005.obj"));
  EXPECT_TRUE(fs::exists(dir / "vtk" / "frame_00005.vtu"));
  EXPECT_EQ(read(dir / "blender" / "001_cloth.pc2"), pc2);
}

// `ccfr sweep resume` continues a cell that writes vtu, pc2 and usda (as animated_body's cells in
// configs/sweeps/paper*.yaml do): on main such a cell stayed `terminated` for good. The finished
// cell equals the same run by hand, byte for byte.
TEST(SweepResume, ACellWritingEveryFormatIsResumedByteForByte) {
  const fs::path root = ccfr::test::scratch_dir("resume_formats_sweep");
  write(root / "s.yaml", "configs: [" + config("stress/cloth_near_floor.yaml") +
                             "]\nsolvers: [ccfr]\nframes: 30\nset: {output.formats: '[obj, vtu, pc2, usda]', "
                             "output.checkpoint_every: 3}\n");
  const fs::path out = fs::absolute(root / "sweep");
  const auto r = run_ccfr("run '" + config("stress/cloth_near_floor.yaml") +
                          "' --frames 30 --solver ccfr --set 'output.formats=[obj, vtu, pc2, usda]' --set "
                          "output.checkpoint_every=3 --out '" +
                          (root / "by_hand").string() + "' --log-level warn");
  ASSERT_EQ(r.code, 0) << r.out;
  const fs::path cell = out / "cloth_near_floor__ccfr";
  const int status =
      run_and_interrupt({"sweep", (root / "s.yaml").string(), "--out", out.string(), "--log-level", "warn"}, cell, 3,
                        SIGTERM, root / "sweep.log");
  ASSERT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 143) << read(root / "sweep.log");
  ASSERT_NE(read(cell / "run.json").find("terminated after frame"), std::string::npos) << read(cell / "run.json");
  EXPECT_NE(read(root / "sweep.log").find("next: ccfr sweep resume " + out.string()), std::string::npos)
      << read(root / "sweep.log");
  auto res = run_ccfr("sweep resume '" + out.string() + "' --log-level warn");
  ASSERT_EQ(res.code, 0) << res.out;
  EXPECT_NE(res.out.find("next: ccfr sweep collect " + out.string()), std::string::npos) << res.out;
  const auto a = run_files(root / "by_hand"), b = run_files(cell);
  std::vector<std::string> names_a, names_b;
  for (const auto& [n, _] : a) names_a.push_back(n);
  for (const auto& [n, _] : b) names_b.push_back(n);
  ASSERT_EQ(names_a, names_b);
  for (const auto& [n, bytes] : a) EXPECT_TRUE(bytes == b.at(n)) << n << " differs";
  EXPECT_EQ(a.count("usd/scene.usda"), 1u);
  EXPECT_EQ(nlohmann::json::parse(read(cell / "run.json"))["status"], "completed");

  // collect ends with its time and the next command; every cell passes, so: look at one.
  res = run_ccfr("sweep collect '" + out.string() + "' --no-plot");
  ASSERT_EQ(res.code, 0) << res.out;
  EXPECT_NE(res.out.find("sweep collect: 1 cells, 1 passed the audit, 0 not completed, in "), std::string::npos)
      << res.out;
  EXPECT_NE(res.out.find("; next: ccfr render " + cell.string() + " --sheet\n"), std::string::npos) << res.out;
}

}  // namespace

namespace {

// The run directory of a 4-frame cloth run (checkpoint_every 2) stopped after 3 frames, with its
// run.json set back to "running": what a run killed after its checkpoint of frame 2 leaves.
// Empty (with a test failure) if the run or the edit did not work.
fs::path killed_after_checkpoint(const std::string& name) {
  const fs::path root = ccfr::test::scratch_dir(name);
  const fs::path dir = root / "run";
  const fs::path scene = ccfr::test::write_text(
      root, "s.yaml",
      "time: {frames: 4, substeps: 1}\noutput: {checkpoint_every: 2}\nobjects:\n"
      "  - {name: sheet, kind: cloth, shape: {type: grid, size: [0.1, 0.1], resolution: [2, 2]}}\n");
  const auto r = run_ccfr("run '" + scene.string() + "' --frames 3 --out '" + dir.string() + "' -q");
  EXPECT_EQ(r.code, 0) << r.out;
  std::string json = read(dir / "run.json");
  const auto at = json.find("\"completed\"");
  EXPECT_NE(at, std::string::npos) << json;
  if (r.code != 0 || at == std::string::npos) return {};
  write(dir / "run.json", json.replace(at, 11, "\"running\""));
  return dir;
}

}  // namespace

// A checkpoint whose frame lies beyond time.frames (hand-edited, CRC recomputed) is refused at
// once; it used to stat frame files towards frame_2147483647.obj for hours first.
TEST(Checkpoint, FrameBeyondTheRunIsRefusedBeforeLookingForFrames) {
  const fs::path dir = killed_after_checkpoint("checkpoint_frame_beyond");
  ASSERT_FALSE(dir.empty());
  const fs::path file = ccfr::io::checkpoint_path(dir, 2);
  ccfr::io::Checkpoint c = ccfr::io::read_checkpoint(file);
  for (const int frame : {2147483647}) {
    c.sim.frame = frame;
    write(file, ccfr::io::encode_checkpoint(c));
    const auto r =
        ccfr::test::run_shell("timeout 20 " + std::string(CCFR_EXE) + " run --resume '" + dir.string() + "' 2>&1");
    EXPECT_NE(r.code, 0) << r.out;
    EXPECT_NE(r.code, 124) << "timed out: " << r.out;
    EXPECT_NE(r.out.find("is at frame " + std::to_string(frame)), std::string::npos) << r.out;
  }
}

// A SIGKILL while a checkpoint is written leaves checkpoint_NNNNN.ccfr.tmpPID: the resume removes it
// as it removes a frame's temporary file (it stayed for good).
TEST(Checkpoint, ResumeRemovesTheTemporaryFileOfAKilledCheckpointWrite) {
  const fs::path dir = killed_after_checkpoint("checkpoint_tmp_left");
  ASSERT_FALSE(dir.empty());
  const fs::path tmp = dir / "checkpoints" / "checkpoint_00004.ccfr.tmp12345";
  write(tmp, "half a checkpoint");
  const auto r = run_ccfr("run --resume '" + dir.string() + "' -q");
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_FALSE(fs::exists(tmp)) << r.out;
}
