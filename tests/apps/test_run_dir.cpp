// Nothing a user owns is lost or mixed up (issue 37, items 1, 2 and 5): a rerun replaces ccfr's own
// files of a run directory and nothing else, a previous run that cannot be replaced is said so and
// leaves no DIR.ccfr-new, one writer per directory (a second is refused naming the first; a killed
// one's lock is taken over), `ablate` never overwrites a user's folder and fails with its solvers,
// and SIGINT / SIGTERM to `sweep` and `ablate` stop their cells cleanly. Runs the real binary.
#include <fcntl.h>
#include <grp.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "ccfr/io/dir_lock.hpp"
#include "ccfr/io/run_json.hpp"
#include "cli_support.hpp"

namespace fs = std::filesystem;
using Json = nlohmann::json;
using ccfr::test::read_text;

namespace {

struct Result {
  int code;  // exit code, or -signal
  std::string out;
};

// `ccfr args...` in its own process group (so that a test can end whatever it leaves running),
// stdout + stderr into `log`; as user `uid` when >= 0 (root's permission checks pass everything).
pid_t spawn(const std::vector<std::string>& args, const fs::path& log, int uid = -1, const fs::path& exe = CCFR_EXE) {
  std::vector<std::string> all{exe.string()};
  all.insert(all.end(), args.begin(), args.end());
  const pid_t pid = fork();
  if (pid == 0) {
    ::setpgid(0, 0);
    const int fd = ::open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    ::dup2(fd, 1);
    ::dup2(fd, 2);
    if (uid >= 0 && (::setgroups(0, nullptr) != 0 || ::setgid(uid) != 0 || ::setuid(uid) != 0)) ::_exit(126);
    std::vector<char*> argv;
    for (auto& a : all) argv.push_back(a.data());
    argv.push_back(nullptr);
    ::execv(argv[0], argv.data());
    ::_exit(127);
  }
  ::setpgid(pid, pid);
  return pid;
}

// Waits for `pid` at most `seconds`; kills its whole process group if it has not ended by then.
Result finish(pid_t pid, const fs::path& log, int seconds = 300) {
  int status = 0;
  for (int i = 0; i < seconds * 20; ++i) {
    if (::waitpid(pid, &status, WNOHANG) == pid) {
      ::kill(-pid, SIGKILL);  // anything it left behind
      return {WIFEXITED(status) ? WEXITSTATUS(status) : -WTERMSIG(status), read_text(log)};
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  ::kill(-pid, SIGKILL);
  ::waitpid(pid, &status, 0);
  return {-1000, "(did not end within " + std::to_string(seconds) + " s) " + read_text(log)};
}

// Ends the process group of a spawned ccfr however the test leaves (a failed ASSERT returns early).
struct Reaper {
  pid_t pid;
  ~Reaper() {
    ::kill(-pid, SIGKILL);
    int status = 0;
    ::waitpid(pid, &status, WNOHANG);
  }
};

Result run(const std::vector<std::string>& args, const fs::path& log, int uid = -1, const fs::path& exe = CCFR_EXE) {
  return finish(spawn(args, log, uid, exe), log);
}

bool wait_until(const std::function<bool()>& done, int seconds = 120) {
  for (int i = 0; i < seconds * 100; ++i) {
    if (done()) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  return false;
}

size_t frames_on_disk(const fs::path& dir) { return ccfr::io::list_frames(dir).size(); }

Json run_json(const fs::path& dir) { return Json::parse(read_text(dir / "run.json")); }

void write(const fs::path& p, const std::string& s) {
  fs::create_directories(p.parent_path());
  std::ofstream(p, std::ios::binary) << s;
}

// A sheet over a floor; `frames` long enough that a signal finds it running when large.
std::string scene(int frames = 3, const std::string& extra = "") {
  return "scene: rundir\n"
         "time: {fps: 60, frames: " +
         std::to_string(frames) +
         ", substeps: 2, iterations: 2, xpbd_sweeps: 4}\n"
         "contact: {solver: ccfr, radius: 0.01, offset: 0.005, repulsion_range: 0.001}\n"
         "objects:\n"
         "  - name: sheet\n"
         "    kind: cloth\n"
         "    shape: {type: grid, size: [0.2, 0.2], resolution: [8, 8]}\n"
         "    transform: {translate: [0, 0.02, 0]}\n"
         "  - name: floor\n"
         "    kind: obstacle\n"
         "    shape: {type: plane, size: 1.0, resolution: 2}\n" +
         extra;
}

// The user's files of the tests: path relative to the run directory, and content.
const std::vector<std::pair<std::string, std::string>> kUserFiles{{"NOTES.md", "# what I tried\n"},
                                                                  {"notes.txt", "keep me"},
                                                                  {"analysis/plot.py", "print(1)\n"},
                                                                  {"thesis.tex", "\\documentclass{article}\n"},
                                                                  {"meshes/m.obj", "v 0 0 0\n"}};

void expect_user_files(const fs::path& dir) {
  for (const auto& [name, text] : kUserFiles) EXPECT_EQ(read_text(dir / name), text) << name << " in " << dir;
}

void expect_nothing_beside(const fs::path& dir) {
  EXPECT_FALSE(fs::exists(dir.string() + ".ccfr-new")) << dir;
  EXPECT_FALSE(fs::exists(dir.string() + ".ccfr-old")) << dir;
  EXPECT_FALSE(fs::exists(dir / ccfr::io::kLockFileName)) << "a finished run leaves its lock file";
}

bool contains(const std::string& s, const std::string& part) { return s.find(part) != std::string::npos; }

}  // namespace

// The sequence: --force into the user's folder (its scene file inside), then plain reruns.
TEST(RunDir, ARerunReplacesCcfrsOwnFilesAndKeepsEveryFileOfTheUser) {
  const fs::path d = ccfr::test::scratch_dir("rundir_rerun");
  const fs::path out = d / "exp1";
  for (const auto& [name, text] : kUserFiles) write(out / name, text);
  write(out / "scene.yaml", scene());
  const std::string sc = (out / "scene.yaml").string();

  Result r = run({"run", sc, "--out", out.string(), "--frames", "2", "--force", "-q"}, d / "log1");
  ASSERT_EQ(r.code, 0) << r.out;
  expect_user_files(out);
  // ccfr's own output beside the run (`ccfr render`'s default folder, an audit) is replaced too.
  write(out / "render" / "frame_00000.png", "old picture");
  ASSERT_EQ(run({"audit", out.string()}, d / "audit.log").code, 0);
  ASSERT_TRUE(fs::exists(out / "audit.json"));

  r = run({"run", sc, "--out", out.string(), "--frames", "1", "-q"}, d / "log2");
  ASSERT_EQ(r.code, 0) << r.out;
  expect_user_files(out);
  EXPECT_EQ(read_text(out / "scene.yaml"), scene());
  EXPECT_EQ(frames_on_disk(out), 2u);  // frames 0 and 1 of the rerun, none of the first run's
  EXPECT_EQ(run_json(out)["frames_written"], 2);
  EXPECT_EQ(run_json(out)["status"], "completed");
  EXPECT_FALSE(fs::exists(out / "render"));
  EXPECT_FALSE(fs::exists(out / "audit.json"));
  expect_nothing_beside(out);

  // Again, with the previous run's frames more numerous than the new one's.
  r = run({"run", sc, "--out", out.string(), "--frames", "3", "-q"}, d / "log3");
  ASSERT_EQ(r.code, 0) << r.out;
  r = run({"run", sc, "--out", out.string(), "--frames", "0", "-q"}, d / "log4");
  ASSERT_EQ(r.code, 0) << r.out;
  expect_user_files(out);
  EXPECT_EQ(frames_on_disk(out), 1u);
  expect_nothing_beside(out);
}

TEST(RunDir, ACopiedRunJsonDoesNotMakeTheFolderCcfrsToWipe) {
  const fs::path d = ccfr::test::scratch_dir("rundir_copied");
  const fs::path sc = d / "scene.yaml";
  write(sc, scene());
  ASSERT_EQ(run({"run", sc.string(), "--out", (d / "a").string(), "-q"}, d / "log1").code, 0);
  const fs::path mine = d / "thesis";
  for (const auto& [name, text] : kUserFiles) write(mine / name, text);
  fs::copy_file(d / "a" / "run.json", mine / "run.json");
  const Result r = run({"run", sc.string(), "--out", mine.string(), "--frames", "1", "-q"}, d / "log2");
  ASSERT_EQ(r.code, 0) << r.out;
  expect_user_files(mine);
  EXPECT_EQ(frames_on_disk(mine), 2u);
  expect_nothing_beside(mine);
}

TEST(RunDir, ForceDoesNotOverwriteAFileOfCcfrsNameThatCcfrDidNotWrite) {
  const fs::path d = ccfr::test::scratch_dir("rundir_force");
  const fs::path sc = d / "scene.yaml";
  write(sc, scene());
  const fs::path out = d / "mine";
  write(out / "stats.csv", "my,own,table\n");
  write(out / "frames" / "frame_00000.obj", "o mine\nv 0 0 0\n");
  const Result r = run({"run", sc.string(), "--out", out.string(), "--frames", "1", "--force"}, d / "log");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_TRUE(contains(r.out, "'" + (out / "stats.csv").string() + "'")) << r.out;
  EXPECT_TRUE(contains(r.out, "'" + (out / "frames").string() + "'")) << r.out;
  EXPECT_EQ(read_text(out / "stats.csv"), "my,own,table\n");
  EXPECT_EQ(read_text(out / "frames" / "frame_00000.obj"), "o mine\nv 0 0 0\n");
  EXPECT_FALSE(fs::exists(out / "run.json"));
  EXPECT_FALSE(fs::exists(out / ccfr::io::kLockFileName));
}

TEST(RunDir, AnEmptyOutIsAnErrorNotTheDefaultFolder) {
  const fs::path d = ccfr::test::scratch_dir("rundir_empty_out");
  const std::string stem = "rundir_empty_out_scene";
  write(d / (stem + ".yaml"), scene());
  const fs::path fallback = fs::current_path() / "out" / stem;
  fs::remove_all(fallback);
  Result r = run({"run", (d / (stem + ".yaml")).string(), "--out", ""}, d / "log");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_TRUE(contains(r.out, "--out is empty")) << r.out;
  EXPECT_FALSE(fs::exists(fallback));
  r = run({"ablate", (d / (stem + ".yaml")).string(), "--solvers", "none", "--out", ""}, d / "log2");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_TRUE(contains(r.out, "--out is empty")) << r.out;
}

// A read-only frames/ of the previous run (as a user that permissions apply to: root passes them
// all, so the runs are made as `nobody` then): refused before anything is written, exit 2.
TEST(RunDir, APreviousRunThatCannotBeRemovedIsRefusedUpFrontAndNothingStaysBehind) {
  const int uid = ::geteuid() == 0 ? 65534 : -1;
  const fs::path d =
      uid >= 0 ? ccfr::test::nobody_scratch_dir("rundir_readonly") : ccfr::test::scratch_dir("rundir_readonly");
  const fs::path exe = uid >= 0 ? ccfr::test::nobody_exe(d) : fs::path(CCFR_EXE);
  if (uid >= 0) fs::permissions(d, fs::perms::all);  // nobody writes here; the test's own files are read only
  const fs::path sc = d / "scene.yaml";
  write(sc, scene());
  const fs::path out = d / "out";
  ASSERT_EQ(run({"run", sc.string(), "--out", out.string(), "-q"}, d / "log1", uid, exe).code, 0)
      << read_text(d / "log1");
  const std::string start = run_json(out)["start_time"];
  fs::permissions(out / "frames", fs::perms::owner_read | fs::perms::owner_exec | fs::perms::group_read |
                                      fs::perms::group_exec | fs::perms::others_read | fs::perms::others_exec);
  const Result r = run({"run", sc.string(), "--out", out.string(), "--frames", "1"}, d / "log2", uid, exe);
  fs::permissions(out / "frames", fs::perms::owner_write, fs::perm_options::add);
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_TRUE(contains(r.out, "'" + (out / "frames").string() + "' is not writable")) << r.out;
  EXPECT_TRUE(contains(r.out, "Nothing was changed")) << r.out;
  EXPECT_EQ(run_json(out)["start_time"], start);
  EXPECT_EQ(frames_on_disk(out), 4u);
  expect_nothing_beside(out);
}

// A frame of the previous run that even root cannot remove (chattr +i) passes the check up front
// and fails only once the new run is in place: the run says where the previous run's files are
// (DIR.ccfr-old) and why, exits 1, and the next run into DIR removes them.
TEST(RunDir, APreviousRunThatCannotBeRemovedAfterwardsIsReportedWithWhereItIs) {
  // An earlier run of this test that stopped half-way may have left the flag set.
  std::system(("chattr -R -i '" + ccfr::test::scratch_path("rundir_immutable").string() + "' 2>/dev/null").c_str());
  const fs::path d = ccfr::test::scratch_dir("rundir_immutable");
  const fs::path sc = d / "scene.yaml";
  write(sc, scene());
  const fs::path out = d / "out";
  ASSERT_EQ(run({"run", sc.string(), "--out", out.string(), "-q"}, d / "log1").code, 0);
  write(out / "NOTES.md", "mine\n");
  const fs::path stuck = out / "frames" / "frame_00003.obj";
  if (::geteuid() != 0 || std::system(("chattr +i '" + stuck.string() + "' 2>/dev/null").c_str()) != 0)
    GTEST_SKIP() << "chattr +i is not available here";
  const Result r = run({"run", sc.string(), "--out", out.string(), "--frames", "1"}, d / "log2");
  const fs::path old = out.string() + ".ccfr-old";
  std::system(("chattr -i '" + (old / "frames" / "frame_00003.obj").string() + "' 2>/dev/null").c_str());
  std::system(("chattr -i '" + stuck.string() + "' 2>/dev/null").c_str());
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_TRUE(contains(r.out, "the previous run's files could not be removed")) << r.out;
  EXPECT_TRUE(contains(r.out, "they are in '" + old.string() + "'")) << r.out;
  EXPECT_EQ(run_json(out)["status"], "completed");
  EXPECT_EQ(frames_on_disk(out), 2u);
  EXPECT_EQ(read_text(out / "NOTES.md"), "mine\n");
  EXPECT_FALSE(fs::exists(out.string() + ".ccfr-new"));
  const Result again = run({"run", sc.string(), "--out", out.string(), "--frames", "1"}, d / "log3");
  EXPECT_EQ(again.code, 0) << again.out;
  expect_nothing_beside(out);
}

// A rerun killed during the few renames that put it in place (assembled here from two real runs):
// the next writer undoes it when the previous run was not all moved out yet, finishes it when it
// was (the marker in DIR.ccfr-old), and says so; the user's files never move.
TEST(RunDir, ARerunKilledWhilePuttingItselfInPlaceIsUndoneOrFinishedByTheNext) {
  const fs::path d = ccfr::test::scratch_dir("rundir_killed_commit");
  const fs::path sc = d / "scene.yaml";
  write(sc, scene());
  for (const char* name : {"prev", "next"})
    ASSERT_EQ(
        run({"run", sc.string(), "--out", (d / name).string(), "--frames", name[0] == 'p' ? "3" : "1", "-q"}, d / "log")
            .code,
        0);
  for (const bool marker : {false, true}) {
    const fs::path out = d / (marker ? "finish" : "undo");
    const fs::path old = out.string() + ".ccfr-old", staged = out.string() + ".ccfr-new";
    fs::copy(d / "prev", out, fs::copy_options::recursive);
    fs::copy(d / "next", staged, fs::copy_options::recursive);
    for (const auto& [name, text] : kUserFiles) write(out / name, text);
    fs::create_directories(old);
    fs::rename(out / "run.json", old / "run.json");  // the previous run half moved out
    if (marker) {
      // ... all of it moved out, and the new run's frames/ already in.
      fs::rename(out / "frames", old / "frames");
      fs::rename(out / "stats.csv", old / "stats.csv");
      write(old / ".ccfr-commit", "");
      fs::rename(staged / "frames", out / "frames");
    }
    const Result r = run({"run", sc.string(), "--out", out.string(), "--frames", "2"}, d / "log2");
    EXPECT_EQ(r.code, 0) << r.out;
    EXPECT_TRUE(contains(r.out, marker ? "finished replacing the run in '" + out.string() + "'"
                                       : "restored the previous run in '" + out.string() + "'"))
        << r.out;
    expect_user_files(out);
    EXPECT_EQ(run_json(out)["frames_written"], 3);
    EXPECT_EQ(run_json(out)["status"], "completed");
    expect_nothing_beside(out);
  }
}

TEST(RunLock, ASecondWriterIsRefusedNamingTheFirst) {
  const fs::path d = ccfr::test::scratch_dir("runlock_second");
  const fs::path sc = d / "scene.yaml";
  write(sc, scene(100000, "output: {checkpoint_every: 1}\n"));
  const fs::path out = d / "out";
  const pid_t first = spawn({"run", sc.string(), "--out", out.string(), "--threads", "1"}, d / "log1");
  const Reaper reaper{first};
  ASSERT_TRUE(wait_until([&] { return frames_on_disk(out) >= 3; })) << read_text(d / "log1");
  const auto holder = ccfr::io::lock_holder(out);
  ASSERT_TRUE(holder.has_value());
  EXPECT_EQ(holder->pid, first);

  const std::string who = "pid " + std::to_string(first);
  for (const auto& args : std::vector<std::vector<std::string>>{
           {"run", sc.string(), "--out", out.string(), "--frames", "1"},
           {"run", sc.string(), "--out", out.string() + "/", "--frames", "1", "--force"},
           {"run", "--resume", out.string()}}) {
    const Result r = run(args, d / "log2");
    EXPECT_EQ(r.code, 2) << r.out;
    EXPECT_TRUE(contains(r.out, "is being written by another ccfr process (" + who)) << r.out;
    EXPECT_TRUE(contains(r.out, "ccfr run " + sc.string() + " --out " + out.string())) << r.out;
  }
  EXPECT_EQ(run_json(out)["status"], "running");  // the first run is undisturbed
  ::kill(first, SIGTERM);
  const Result r1 = finish(first, d / "log1");
  EXPECT_EQ(r1.code, 1) << r1.out;
  EXPECT_FALSE(ccfr::io::lock_holder(out).has_value());
  EXPECT_FALSE(fs::exists(out / ccfr::io::kLockFileName));
  const Result again = run({"run", sc.string(), "--out", out.string(), "--frames", "1"}, d / "log3");
  EXPECT_EQ(again.code, 0) << again.out;
}

TEST(RunLock, TheStaleLockOfAKilledRunIsTakenOver) {
  const fs::path d = ccfr::test::scratch_dir("runlock_stale");
  const fs::path sc = d / "scene.yaml";
  write(sc, scene(100000, "output: {checkpoint_every: 1}\n"));
  const fs::path out = d / "out";
  const pid_t first = spawn({"run", sc.string(), "--out", out.string(), "--threads", "1"}, d / "log1");
  const Reaper reaper{first};
  ASSERT_TRUE(wait_until([&] { return frames_on_disk(out) >= 3; })) << read_text(d / "log1");
  ::kill(first, SIGKILL);
  finish(first, d / "log1");
  ASSERT_TRUE(fs::exists(out / ccfr::io::kLockFileName));  // the record of the killed run stays
  EXPECT_FALSE(ccfr::io::lock_holder(out).has_value());
  const Result r = run({"run", sc.string(), "--out", out.string(), "--frames", "1"}, d / "log2");
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_TRUE(
      contains(r.out, "took over the stale lock of '" + out.string() + "' left by pid " + std::to_string(first)))
      << r.out;
  expect_nothing_beside(out);

  // A folder holding nothing but a stale lock file is an empty folder: no --force needed.
  const fs::path fresh = d / "fresh";
  write(fresh / ccfr::io::kLockFileName, "{\"pid\": " + std::to_string(first) + ", \"command\": \"ccfr run x\"}\n");
  const Result f = run({"run", sc.string(), "--out", fresh.string(), "--frames", "1"}, d / "log3");
  EXPECT_EQ(f.code, 0) << f.out;
  expect_nothing_beside(fresh);
}

TEST(Ablate, AFolderThatIsNotAnAblationIsRefusedAndItsTableKept) {
  const fs::path d = ccfr::test::scratch_dir("ablate_users_folder");
  const fs::path sc = d / "scene.yaml";
  write(sc, scene());
  const fs::path out = d / "mine";
  write(out / "ablation.csv", "solver,my numbers\n");
  Result r =
      run({"ablate", sc.string(), "--solvers", "none", "--frames", "1", "--no-plot", "--out", out.string()}, d / "log");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_TRUE(contains(r.out, "is not empty and is not a ccfr ablation")) << r.out;
  EXPECT_EQ(read_text(out / "ablation.csv"), "solver,my numbers\n");
  EXPECT_FALSE(fs::exists(out / "sweep.json"));
  EXPECT_FALSE(fs::exists(out / "none"));

  // Its own earlier ablation is rerun into.
  const fs::path a = d / "a";
  r = run({"ablate", sc.string(), "--solvers", "none", "--frames", "1", "--no-plot", "--out", a.string()}, d / "l2");
  ASSERT_EQ(r.code, 0) << r.out;
  r = run({"ablate", sc.string(), "--solvers", "none", "--frames", "1", "--no-plot", "--out", a.string()}, d / "l3");
  EXPECT_EQ(r.code, 0) << r.out;
}

TEST(Ablate, ARerunWithOtherFramesRunsTheSolversAgainInsteadOfReusingTheirRuns) {
  const fs::path d = ccfr::test::scratch_dir("ablate_rerun_frames");
  write(d / "scene.yaml", scene());
  const fs::path a = d / "a";
  for (const char* frames : {"1", "2"}) {
    const Result r = run({"ablate", (d / "scene.yaml").string(), "--solvers", "none", "--frames", frames, "--no-plot",
                          "--out", a.string()},
                         d / "log");
    ASSERT_EQ(r.code, 0) << r.out;
    EXPECT_TRUE(contains(read_text(a / "ablation.csv"), "\nnone," + std::string(frames) + ",completed,"))
        << read_text(a / "ablation.csv");
  }
  EXPECT_EQ(run_json(a / "none")["frames_written"], 3);
}

TEST(Ablate, ASolverWhoseRunFailedFailsTheAblation) {
  const fs::path d = ccfr::test::scratch_dir("ablate_failed_cell");
  std::string text = scene();
  text.replace(text.find("time: {fps: 60"), 14, "time: {fps: 0.001, gravity: [0, -1e4, 0]");  // g dt^2 >> 1e6
  write(d / "scene.yaml", text);
  const Result r = run({"ablate", (d / "scene.yaml").string(), "--solvers", "none", "--frames", "2", "--no-plot",
                        "--out", (d / "a").string()},
                       d / "log");
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_TRUE(contains(r.out, "1 failed to run")) << r.out;
}

namespace {
std::string sweep_spec(const fs::path& scene_file, int frames) {
  return "configs: [" + scene_file.string() +
         "]\nsolvers: [ccfr, exact_projection]\nframes: " + std::to_string(frames) +
         "\nset: {output.checkpoint_every: 1000, contact.on_violation: warn}\n";
}
const std::vector<std::string> kCells{"scene__ccfr", "scene__exact_projection"};
}  // namespace

TEST(SweepSignals, SigintStopsEveryRunningCellWhichWritesItsCheckpointAndStatus) {
  const fs::path d = ccfr::test::scratch_dir("sweep_sigint");
  write(d / "scene.yaml", scene());
  write(d / "spec.yaml", sweep_spec(d / "scene.yaml", 100000));
  const fs::path s = d / "sweep";
  const pid_t pid =
      spawn({"sweep", (d / "spec.yaml").string(), "--out", s.string(), "--jobs", "2", "--threads", "1"}, d / "log");
  const Reaper reaper{pid};
  ASSERT_TRUE(wait_until([&] {
    for (const auto& c : kCells)
      if (frames_on_disk(s / c) < 3) return false;
    return true;
  })) << read_text(d / "log");
  ::kill(pid, SIGINT);  // to the sweep alone, as `kill -INT`; not to its process group
  const Result r = finish(pid, d / "log", 120);
  EXPECT_EQ(r.code, 130) << r.out;
  EXPECT_TRUE(contains(r.out, "stopped by SIGINT")) << r.out;
  for (const auto& c : kCells) {
    const Json j = run_json(s / c);
    const std::string status = j["status"];
    ASSERT_EQ(status.rfind("interrupted after frame ", 0), 0u) << c << ": " << status;
    const int frame = std::stoi(status.substr(24));
    char name[40];
    std::snprintf(name, sizeof name, "checkpoint_%05d.ccfr", frame);
    EXPECT_TRUE(fs::exists(s / c / "checkpoints" / name)) << c << ": " << status;
    EXPECT_EQ(Json::parse(read_text(s / "logs" / (c + ".json")))["status"], status);
    // The cell's process ended before the sweep did: its lock is released.
    EXPECT_FALSE(fs::exists(s / c / ccfr::io::kLockFileName)) << c;
  }
  const auto st = ccfr::test::run_ccfr("sweep status '" + s.string() + "'");
  EXPECT_TRUE(contains(st.out, "2 cells: 2 interrupted")) << st.out;
}

TEST(SweepSignals, SigtermStopsAnAblationAndTheSolverItRuns) {
  const fs::path d = ccfr::test::scratch_dir("ablate_sigterm");
  write(d / "scene.yaml", scene());
  const fs::path a = d / "a";
  const pid_t pid = spawn({"ablate", (d / "scene.yaml").string(), "--solvers", "ccfr,none", "--frames", "100000",
                           "--no-plot", "--threads", "1", "--out", a.string()},
                          d / "log");
  const Reaper reaper{pid};
  ASSERT_TRUE(wait_until([&] { return frames_on_disk(a / "ccfr") >= 3; })) << read_text(d / "log");
  ::kill(pid, SIGTERM);
  const Result r = finish(pid, d / "log", 120);
  EXPECT_EQ(r.code, 143) << r.out;
  const std::string status = run_json(a / "ccfr")["status"];
  EXPECT_EQ(status.rfind("terminated after frame ", 0), 0u) << status;
  EXPECT_FALSE(fs::exists(a / "none" / "run.json"));  // no further solver started
  EXPECT_FALSE(fs::exists(a / "ccfr" / ccfr::io::kLockFileName));
}

// The sweep process is killed outright (SIGKILL: nothing can pass it on): its cell runs on. Status
// says it runs, resume leaves it alone, and a second run-cell of it is refused.
TEST(SweepSignals, ResumeNeverStartsASecondWriterOnACellStillRunning) {
  const fs::path d = ccfr::test::scratch_dir("sweep_orphan");
  write(d / "scene.yaml", scene());
  // Bounded, so that a binary without the lock still ends (and the test fails rather than hangs).
  write(d / "spec.yaml", "configs: [" + (d / "scene.yaml").string() +
                             "]\nsolvers: [ccfr]\nframes: 3000\nset: {output.checkpoint_every: 1}\n");
  const fs::path s = d / "sweep";
  const pid_t pid = spawn({"sweep", (d / "spec.yaml").string(), "--out", s.string(), "--threads", "1"}, d / "log");
  const Reaper reaper{pid};
  const fs::path cell = s / "scene__ccfr";
  ASSERT_TRUE(wait_until([&] { return frames_on_disk(cell) >= 3; })) << read_text(d / "log");
  ::kill(pid, SIGKILL);
  int st = 0;
  ::waitpid(pid, &st, 0);
  const auto holder = ccfr::io::lock_holder(cell);
  EXPECT_TRUE(holder.has_value());

  const auto status = ccfr::test::run_ccfr("sweep status '" + s.string() + "'");
  EXPECT_TRUE(contains(status.out, "1 cells: 1 running")) << status.out;
  const auto resumed = ccfr::test::run_ccfr("sweep resume '" + s.string() + "'");
  EXPECT_EQ(resumed.code, 0) << resumed.out;
  EXPECT_TRUE(contains(resumed.out, "nothing to resume")) << resumed.out;
  const auto second = ccfr::test::run_ccfr("sweep run-cell '" + s.string() + "' 0");
  EXPECT_EQ(second.code, 2) << second.out;
  if (holder) EXPECT_TRUE(contains(second.out, "pid " + std::to_string(holder->pid))) << second.out;
  ::kill(-pid, SIGKILL);  // the orphaned cell
}
