// Faults lose nothing: SIGTERM / SIGKILL mid-run, failed writes, reruns into an existing
// directory, and run.json that stays valid JSON whatever the strings in it. Runs the real binary.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <regex>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "ccfr/core/process.hpp"
#include "ccfr/io/obj.hpp"
#include "ccfr/io/run_json.hpp"
#include "cli_support.hpp"

namespace fs = std::filesystem;
using Json = nlohmann::json;

namespace {

fs::path scratch(const std::string& name) {
  const fs::path d = ccfr::test::scratch_path("faults_" + name);
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}

std::string read(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

Json run_json(const fs::path& dir) { return Json::parse(read(dir / "run.json")); }  // throws if invalid

struct Result {
  int code;  // exit code, or -signal
  std::string out;
};

Result finish(pid_t pid, const fs::path& log) {
  int status = 0;
  ::waitpid(pid, &status, 0);
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -WTERMSIG(status), read(log)};
}

Result run(const std::vector<std::string>& args, const fs::path& log, rlim_t fsize_limit = 0) {
  return finish(ccfr::test::spawn_ccfr(args, log, fsize_limit), log);
}

size_t count_frames(const fs::path& dir) { return ccfr::io::list_frames(dir).size(); }

std::vector<std::string> temporaries(const fs::path& dir) {
  std::vector<std::string> t;
  for (const auto& e : fs::recursive_directory_iterator(dir))
    if (e.path().filename().string().find(".tmp") != std::string::npos) t.push_back(e.path().string());
  return t;
}

/// Waits until DIR/frames holds at least n frames (false after 60 s).
bool wait_for_frames(const fs::path& dir, size_t n) {
  for (int i = 0; i < 6000; ++i) {
    if (fs::is_directory(dir / "frames") && count_frames(dir) >= n) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  return false;
}

/// Every line of stats.csv is a whole row (as many columns as the header, newline-terminated).
size_t check_stats_rows(const fs::path& csv) {
  const std::string s = read(csv);
  EXPECT_FALSE(s.empty());
  EXPECT_EQ(s.back(), '\n') << "stats.csv ends in a partial row";
  std::stringstream ss(s);
  std::string header, line;
  std::getline(ss, header);
  const auto cols = std::count(header.begin(), header.end(), ',');
  size_t rows = 0;
  while (std::getline(ss, line)) {
    EXPECT_EQ(std::count(line.begin(), line.end(), ','), cols) << "truncated row: " << line;
    ++rows;
  }
  return rows;
}

// Long enough that a run is still going when the test signals it.
std::string scene(int grid = 8, const std::string& extra = "") {
  return "scene: faults\n"
         "time: {fps: 60, frames: 3, substeps: 2, iterations: 2, xpbd_sweeps: 4}\n"
         "contact: {solver: ccfr, radius: 0.01, offset: 0.005, repulsion_range: 0.001}\n"
         "objects:\n"
         "  - name: sheet\n"
         "    kind: cloth\n"
         "    shape: {type: grid, size: [" +
         std::to_string(0.025 * grid) + ", " + std::to_string(0.025 * grid) + "], resolution: [" +
         std::to_string(grid) + ", " + std::to_string(grid) +
         "]}\n"
         "    transform: {translate: [0, 0.02, 0]}\n"
         "  - name: floor\n"
         "    kind: obstacle\n"
         "    shape: {type: plane, size: 1.0, resolution: 2}\n" +
         extra;
}

fs::path write_scene(const fs::path& d, const std::string& text) {
  std::ofstream(d / "scene.yaml") << text;
  return d / "scene.yaml";
}

}  // namespace

TEST(Faults, SigtermStopsAfterAWholeFrameAndRecordsIt) {
  const fs::path d = scratch("sigterm");
  const fs::path sc = write_scene(d, scene());
  const fs::path out = d / "out";
  const pid_t pid = ccfr::test::spawn_ccfr(
      {"run", sc.string(), "--out", out.string(), "--frames", "100000", "--threads", "1"}, d / "log");
  ASSERT_TRUE(wait_for_frames(out, 3));
  ::kill(pid, SIGTERM);
  const Result r = finish(pid, d / "log");
  EXPECT_EQ(r.code, 1) << r.out;
  const Json j = run_json(out);
  const std::string status = j["status"];
  EXPECT_EQ(status.rfind("terminated after frame ", 0), 0u) << status;
  EXPECT_NE(status.find("SIGTERM"), std::string::npos) << status;
  EXPECT_TRUE(j["end_time"].is_string());
  const size_t frames = count_frames(out);
  EXPECT_EQ(j["frames_written"].get<size_t>(), frames);
  for (const auto& f : ccfr::io::list_frames(out)) {
    const auto fr = ccfr::io::read_frame_obj(f);  // whole: parses, every vertex there
    EXPECT_EQ(fr.v.size(), ccfr::io::read_frame_obj(out / "frames" / "frame_00000.obj").v.size()) << f;
  }
  EXPECT_EQ(check_stats_rows(out / "stats.csv"), frames - 1);  // frame 0 has no row
  EXPECT_TRUE(temporaries(out).empty());
  // The audit accepts a stopped run with --partial: run.json and the frames agree.
  const Result a = run({"audit", out.string(), "--partial", "--stride", "1000"}, d / "audit.log");
  EXPECT_EQ(a.code, 0) << a.out;
}

TEST(Faults, SigkillLeavesFramesWrittenMatchingTheFramesOnDisk) {
  const fs::path d = scratch("sigkill");
  const fs::path sc = write_scene(d, scene());
  const fs::path out = d / "out";
  const pid_t pid = ccfr::test::spawn_ccfr(
      {"run", sc.string(), "--out", out.string(), "--frames", "100000", "--threads", "1"}, d / "log");
  ASSERT_TRUE(wait_for_frames(out, 5));
  ::kill(pid, SIGKILL);
  const Result r = finish(pid, d / "log");
  EXPECT_EQ(r.code, -SIGKILL);
  const Json j = run_json(out);
  EXPECT_EQ(j["status"], "running");
  const long frames = static_cast<long>(count_frames(out));
  const long written = j["frames_written"].get<long>();
  EXPECT_GE(written, 5 - 1);
  EXPECT_LE(std::abs(written - frames), 1) << "run.json says " << written << ", " << frames << " on disk";
  for (const auto& f : ccfr::io::list_frames(out)) EXPECT_NO_THROW(ccfr::io::read_frame_obj(f)) << f;
  check_stats_rows(out / "stats.csv");

  // A rerun cleans the temporaries a crash leaves behind.
  std::ofstream(out / "frames" / "frame_00099.obj.tmp4242") << "o half\nv 0 0";
  const Result again = run({"run", sc.string(), "--out", out.string(), "--frames", "2"}, d / "log2");
  ASSERT_EQ(again.code, 0) << again.out;
  EXPECT_TRUE(temporaries(out).empty());
  EXPECT_EQ(count_frames(out), 3u);
  EXPECT_EQ(run_json(out)["status"], "completed");
}

TEST(Faults, AFailedFrameWriteStopsTheRunAndLeavesNoTemporary) {
  const fs::path d = scratch("framewrite");
  // A frame of this sheet is far larger than the 16 KiB a file may grow to; run.json is smaller.
  const fs::path sc = write_scene(d, scene(30));
  const fs::path out = d / "out";
  // Little logging: the log file is under the same size limit.
  const Result r =
      run({"run", sc.string(), "--out", out.string(), "--frames", "5", "--log-level", "warn"}, d / "log", 16384);
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_NE(r.out.find("cannot write '" + (out / "frames" / "frame_00000.obj").string() + "': File too large"),
            std::string::npos)
      << r.out;
  const Json j = run_json(out);
  EXPECT_EQ(j["status"].get<std::string>().rfind("failed: cannot write '", 0), 0u) << j["status"];
  EXPECT_NE(j["status"].get<std::string>().find("frame_00000.obj"), std::string::npos);
  EXPECT_EQ(j["frames_written"], 0);
  EXPECT_EQ(count_frames(out), 0u);
  EXPECT_TRUE(temporaries(out).empty()) << temporaries(out).front();
  EXPECT_EQ(check_stats_rows(out / "stats.csv"), 0u) << "the run must not go on after a failed write";
}

TEST(Faults, AFailedStatsWriteStopsTheRunWithoutAPartialRow) {
  const fs::path d = scratch("statswrite");
  // No checkpoints either: they are larger than a stats row and would hit the limit first.
  const fs::path sc = write_scene(d, scene(4, "output: {frames: false, checkpoint_every: 0}\n"));
  // Size of run.json on a run that succeeds; the limit lets run.json through and stops stats.csv
  // part-way through a row (rows are ~150 bytes).
  ASSERT_EQ(
      run({"run", sc.string(), "--out", (d / "ref").string(), "--frames", "1", "--log-level", "warn"}, d / "ref.log")
          .code,
      0);
  const rlim_t limit = fs::file_size(d / "ref" / "run.json") + 1111;
  const fs::path out = d / "out";
  const Result r =
      run({"run", sc.string(), "--out", out.string(), "--frames", "400", "--log-level", "warn"}, d / "log", limit);
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_NE(r.out.find("cannot write '" + (out / "stats.csv").string() + "': File too large"), std::string::npos)
      << r.out;
  const size_t rows = check_stats_rows(out / "stats.csv");
  EXPECT_GT(rows, 0u);
  EXPECT_LT(rows, 400u);
  const Json j = run_json(out);
  EXPECT_EQ(j["status"].get<std::string>().rfind("failed: cannot write '", 0), 0u) << j["status"];
  EXPECT_NE(j["status"].get<std::string>().find("stats.csv"), std::string::npos);
}

TEST(Faults, OutOntoADirectoryThatIsNotARunIsRefusedWithoutForce) {
  const fs::path d = scratch("notarun");
  const fs::path sc = write_scene(d, scene());
  const fs::path out = d / "mine";
  fs::create_directories(out / "frames");
  std::ofstream(out / "notes.txt") << "keep me";
  std::ofstream(out / "frames" / "frame_00000.obj") << "o mine\nv 0 0 0\n";
  const Result r = run({"run", sc.string(), "--out", out.string(), "--frames", "1"}, d / "log");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("'" + out.string() + "' is not empty and is not a ccfr run"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("--force"), std::string::npos) << r.out;
  EXPECT_EQ(read(out / "frames" / "frame_00000.obj"), "o mine\nv 0 0 0\n");
  EXPECT_FALSE(fs::exists(out / "run.json"));

  // --force writes beside the user's files, never over one of ccfr's names that ccfr did not write.
  const Result clash = run({"run", sc.string(), "--out", out.string(), "--frames", "1", "--force"}, d / "log2");
  EXPECT_EQ(clash.code, 2) << clash.out;
  EXPECT_NE(clash.out.find("'" + (out / "frames").string() + "' would be overwritten"), std::string::npos) << clash.out;
  EXPECT_EQ(read(out / "frames" / "frame_00000.obj"), "o mine\nv 0 0 0\n");
  fs::rename(out / "frames", d / "my_frames");
  const Result forced = run({"run", sc.string(), "--out", out.string(), "--frames", "1", "--force"}, d / "log3");
  EXPECT_EQ(forced.code, 0) << forced.out;
  EXPECT_EQ(read(out / "notes.txt"), "keep me");
  EXPECT_EQ(run_json(out)["status"], "completed");
  EXPECT_EQ(count_frames(out), 2u);
}

TEST(Faults, ARerunKeepsThePreviousRunUntilItsFirstFrame) {
  const fs::path d = scratch("rerun");
  const fs::path out = d / "out";
  const fs::path good = write_scene(d, scene());
  ASSERT_EQ(run({"run", good.string(), "--out", out.string()}, d / "log").code, 0);
  const std::string old_frame = read(out / "frames" / "frame_00003.obj");
  const std::string old_start = run_json(out)["start_time"];

  // A frame of 1000 s under strong gravity: positions pass +-1e6 in frame 1, where the rerun fails.
  fs::create_directories(d / "bad");
  std::string text = scene();
  text.replace(text.find("time: {fps: 60"), 14, "time: {fps: 0.001, gravity: [0, -1e4, 0]");  // g dt^2 >> 1e6
  const fs::path bad = write_scene(d / "bad", text);
  const Result r = run({"run", bad.string(), "--out", out.string(), "--solver", "none"}, d / "log2");
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_NE(r.out.find("the previous run in"), std::string::npos) << r.out;
  EXPECT_EQ(count_frames(out), 4u);
  EXPECT_EQ(read(out / "frames" / "frame_00003.obj"), old_frame);
  EXPECT_EQ(run_json(out)["status"], "completed");
  EXPECT_EQ(run_json(out)["start_time"], old_start);
  EXPECT_FALSE(fs::exists(d / "out.ccfr-new"));

  // A rerun that gets past its first frame replaces the previous run entirely.
  ASSERT_EQ(run({"run", good.string(), "--out", out.string() + "/", "--frames", "1"}, d / "log3").code, 0);
  EXPECT_EQ(count_frames(out), 2u);
  EXPECT_EQ(run_json(out)["frames_written"], 2);
  EXPECT_EQ(check_stats_rows(out / "stats.csv"), 1u);
  EXPECT_FALSE(fs::exists(d / "out.ccfr-new"));
  EXPECT_FALSE(fs::exists(d / "out.ccfr-old"));
}

TEST(Faults, RunJsonIsValidJsonAndRecordsTheWholeCommandLine) {
  const fs::path d = scratch("json");
  const fs::path sc = write_scene(d, scene());
  // Quotes, a backslash, a tab and control characters in the output path (any byte but / and NUL
  // is allowed in a file name) and in a --set value.
  const fs::path out = d / "we\"ird\\ \t\x01\x1f";
  const std::vector<std::string> args{
      "run",   sc.string(),           "--out", out.string(),     "--frames", "1", "--solver", "ccfr", "--threads", "1",
      "--set", "contact.radius=0.01", "--set", "time.substeps=2"};
  const Result r = run(args, d / "log");
  ASSERT_EQ(r.code, 0) << r.out;
  Json j;
  ASSERT_NO_THROW(j = run_json(out)) << read(out / "run.json");
  std::vector<std::string> expected{"ccfr"};
  expected.insert(expected.end(), args.begin(), args.end());
  EXPECT_EQ(j["argv"].get<std::vector<std::string>>(), expected);
  const std::string cl = j["command_line"];
  for (const char* a :
       {"--frames 1", "--solver ccfr", "--threads 1", "--set contact.radius=0.01", "--set time.substeps=2", "--out "})
    EXPECT_NE(cl.find(a), std::string::npos) << a << " missing in " << cl;
  EXPECT_NE(cl.find("\x01"), std::string::npos);
  // The resolved configuration is JSON inside run.json, not a string holding JSON.
  ASSERT_TRUE(j["config"].is_object());
  EXPECT_EQ(j["config"]["time"]["substeps"], 2);
  EXPECT_EQ(j["scene"], "faults");
  EXPECT_EQ(j["status"], "completed");
  EXPECT_EQ(j["frames_written"], 2);
  // The library reader used by audit and render reads it back.
  EXPECT_EQ(ccfr::io::read_run_info(out).progress.status, "completed");
}

/// The renames docs/output.md calls safe against power loss (run.json, frames, stats, checkpoints)
/// follow an fsync of the temporary file they rename, and are followed by an fsync of the folder
/// that holds it. Read from the system calls ccfr makes (strace), not from its code.
TEST(Faults, AtomicWritesSyncTheFileBeforeTheRenameAndTheFolderAfter) {
  if (!ccfr::find_program("strace")) GTEST_SKIP() << "strace is not installed";
  const fs::path d = scratch("fsync");
  const fs::path sc = write_scene(d, scene());
  const fs::path out = d / "out", trace = d / "trace";
  const auto r =
      ccfr::test::run_shell("strace -f -qq -e trace=openat,fsync,rename,close -o '" + trace.string() + "' " + CCFR_EXE +
                            " run '" + sc.string() + "' --out '" + out.string() + "' --frames 2 --threads 1 -q 2>&1");
  if (r.code != 0 && r.out.find("ptrace") != std::string::npos) GTEST_SKIP() << "ptrace is not permitted: " << r.out;
  ASSERT_EQ(r.code, 0) << r.out;
  // Per fd: the path it was opened on, and whether it was synced since.
  std::map<int, std::pair<std::string, bool>> open_fds;
  std::map<std::string, bool> synced_file;            // temporary path -> synced before its close
  std::vector<std::pair<std::string, bool>> renames;  // (final path, its folder synced after)
  std::ifstream in(trace);
  const std::regex openat(R"re(openat\(AT_FDCWD, "([^"]+)", ([A-Z_|]+)[^)]*\)\s*= (\d+))re");
  const std::regex fsync(R"(fsync\((\d+)\)\s*= 0)"), close(R"(close\((\d+)\))");
  const std::regex rename(R"re(rename\("([^"]+)", "([^"]+)"\)\s*= 0)re");
  for (std::string line; std::getline(in, line);) {
    std::smatch m;
    if (std::regex_search(line, m, openat)) {
      open_fds[std::stoi(m[3])] = {m[1].str(), false};
    } else if (std::regex_search(line, m, fsync)) {
      const auto it = open_fds.find(std::stoi(m[1]));
      if (it == open_fds.end()) continue;
      it->second.second = true;
      synced_file[it->second.first] = true;
      for (auto& [path, folder_synced] : renames)
        if (fs::path(path).parent_path() == fs::path(it->second.first)) folder_synced = true;
    } else if (std::regex_search(line, m, close)) {
      open_fds.erase(std::stoi(m[1]));
    } else if (std::regex_search(line, m, rename)) {
      EXPECT_TRUE(synced_file[m[1].str()]) << m[1] << " renamed without an fsync";
      renames.emplace_back(m[2].str(), false);
    }
  }
  size_t frames = 0, run_json = 0;
  for (const auto& [path, folder_synced] : renames) {
    EXPECT_TRUE(folder_synced) << "the folder of " << path << " was not synced after the rename";
    frames += path.find("frames/frame_") != std::string::npos;
    run_json += path.ends_with("run.json");
  }
  EXPECT_EQ(frames, 3u);  // frames 0, 1 and 2
  EXPECT_GE(run_json, 3u);
}
