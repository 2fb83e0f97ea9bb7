#pragma once
// Running the real `ccfr` binary from tests, and scratch directories private to one build tree:
// several build trees (worktrees, the sanitizer build) may run their suites on one machine at
// once, and a shared /tmp path let one suite delete another's frames mid-audit.
#include <fcntl.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <sstream>
#include <string>
#include <vector>

#include "ccfr/core/error.hpp"

namespace ccfr::test {

struct CliResult {
  int code = -1;    ///< exit code, -1 if the process did not exit normally
  std::string out;  ///< stdout and stderr, interleaved
};

/// Runs a whole shell command line and collects its stdout (redirect stderr in `cmd` to get it).
inline CliResult run_shell(const std::string& cmd) {
  CliResult r;
  FILE* p = popen(cmd.c_str(), "r");
  if (!p) return {-1, "popen failed"};
  std::array<char, 4096> buf;
  while (size_t n = fread(buf.data(), 1, buf.size(), p)) r.out.append(buf.data(), n);
  const int status = pclose(p);
  r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}

/// Runs `CCFR_EXE args` through the shell and collects its output.
inline CliResult run_ccfr(const std::string& args) { return run_shell(std::string(CCFR_EXE) + " " + args + " 2>&1"); }

/// A sheet over a floor, 3 frames (edges 0.05, ξ = 0.005): the smallest scene with contact.
inline std::string sheet_on_floor_scene(const std::string& name) {
  return "scene: " + name + R"(
time: {fps: 60, frames: 3, substeps: 2, iterations: 2, xpbd_sweeps: 4}
contact: {solver: ccfr, radius: 0.01, offset: 0.005, repulsion_range: 0.001}
objects:
  - name: sheet
    kind: cloth
    shape: {type: grid, size: [0.2, 0.2], resolution: [4, 4]}
    transform: {translate: [0, 0.02, 0]}
  - name: floor
    kind: obstacle
    shape: {type: plane, size: 1.0, resolution: 2}
)";
}

struct CliStreams {
  int code = -1;    ///< exit code, -1 if the process did not exit normally
  std::string out;  ///< stdout alone
  std::string err;  ///< stderr alone
};

/// Runs `env CCFR_EXE args` through the shell with stdout and stderr collected apart (stderr
/// through a file in `scratch`); `env` prefixes variables ("CCFR_PYTHON=/bin/false").
inline CliStreams run_ccfr_split(const std::string& args, const std::filesystem::path& scratch,
                                 const std::string& env = "") {
  const std::filesystem::path err = scratch / "stderr.txt";
  const std::string cmd =
      env + (env.empty() ? "" : " ") + std::string(CCFR_EXE) + " " + args + " 2> '" + err.string() + "'";
  CliStreams r;
  FILE* p = popen(cmd.c_str(), "r");
  if (!p) return r;
  std::array<char, 4096> buf;
  while (size_t n = fread(buf.data(), 1, buf.size(), p)) r.out.append(buf.data(), n);
  const int status = pclose(p);
  r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  std::ifstream in(err);
  std::stringstream ss;
  ss << in.rdbuf();
  r.err = ss.str();
  return r;
}

/// BUILD/test-scratch/NAME, not created (for runs that must create it themselves).
inline std::filesystem::path scratch_path(const std::string& name) {
  return std::filesystem::path(CCFR_BINARY_DIR) / "test-scratch" / name;
}

/// BUILD/test-scratch/NAME, emptied and created.
inline std::filesystem::path scratch_dir(const std::string& name) {
  const std::filesystem::path d = scratch_path(name);
  std::filesystem::remove_all(d);
  std::filesystem::create_directories(d);
  return d;
}

/// Whether `nobody` passes `test FLAG PATH` (run through runuser, so only as root): PATH and every
/// directory above it must let others through.
inline bool nobody_can(const char* flag, const std::filesystem::path& path) {
  return std::system(
             ("runuser -u nobody -- test " + std::string(flag) + " '" + path.string() + "' 2>/dev/null").c_str()) == 0;
}

/// A scratch directory for tests that run ccfr as `nobody` (root passes every permission check):
/// BUILD/test-scratch/NAME when nobody can reach the build tree, else one under /tmp private to
/// this build tree, since a checkout inside `mktemp -d` (mode 700) keeps nobody out.
inline std::filesystem::path nobody_scratch_dir(const std::string& name) {
  namespace fs = std::filesystem;
  if (nobody_can("-x", CCFR_BINARY_DIR)) return scratch_dir(name);
  const fs::path root =
      fs::path("/tmp") / ("ccfr-test-nobody-" + std::to_string(std::hash<std::string>{}(CCFR_BINARY_DIR)));
  const fs::path d = root / name;
  fs::remove_all(d);
  fs::create_directories(d);
  fs::permissions(root, fs::perms::owner_all | fs::perms::group_read | fs::perms::group_exec | fs::perms::others_read |
                            fs::perms::others_exec);
  return d;
}

/// The ccfr executable as `nobody` can run it: the build's own, or a copy in `dir` (a
/// nobody_scratch_dir) when nobody cannot reach the build tree.
inline std::filesystem::path nobody_exe(const std::filesystem::path& dir) {
  namespace fs = std::filesystem;
  if (nobody_can("-x", CCFR_EXE)) return CCFR_EXE;
  const fs::path copy = dir / "ccfr";
  fs::copy_file(CCFR_EXE, copy, fs::copy_options::overwrite_existing);
  fs::permissions(copy, fs::perms::owner_all | fs::perms::group_read | fs::perms::group_exec | fs::perms::others_read |
                            fs::perms::others_exec);
  return copy;
}

inline std::string read_text(const std::filesystem::path& p) {
  std::ifstream in(p);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

/// Writes `text` to dir/name and returns that path (input files for the readers' tests).
inline std::filesystem::path write_text(const std::filesystem::path& dir, const std::string& name,
                                        const std::string& text) {
  std::ofstream(dir / name) << text;
  return dir / name;
}

/// The message of the ccfr::Error that `f` throws, or "(no error)".
inline std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "(no error)";
}

/// Starts `ccfr args...` with stdout + stderr into `log`; `fsize_limit` > 0 caps the size of any
/// file it writes (RLIMIT_FSIZE: writes past it fail with EFBIG, a real kernel write error).
/// The cells of column `name` of a CSV file with a header row (stats.csv), one per data row;
/// empty strings when the column does not exist.
inline std::vector<std::string> csv_column(const std::filesystem::path& csv, const std::string& name) {
  std::ifstream in(csv);
  std::string line;
  std::getline(in, line);
  std::stringstream header(line);
  int index = -1, k = 0;
  for (std::string h; std::getline(header, h, ','); ++k)
    if (h == name) index = k;
  std::vector<std::string> out;
  while (std::getline(in, line)) {
    std::stringstream row(line);
    std::string cell;
    for (int i = 0; i <= index && std::getline(row, cell, ','); ++i) {
    }
    out.push_back(index < 0 ? std::string() : cell);
  }
  return out;
}

inline pid_t spawn_ccfr(const std::vector<std::string>& args, const std::filesystem::path& log,
                        rlim_t fsize_limit = 0) {
  std::vector<std::string> all{CCFR_EXE};
  all.insert(all.end(), args.begin(), args.end());
  const pid_t pid = fork();
  if (pid == 0) {
    const int fd = ::open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    ::dup2(fd, 1);
    ::dup2(fd, 2);
    if (fsize_limit > 0) {
      const rlimit rl{fsize_limit, fsize_limit};
      ::setrlimit(RLIMIT_FSIZE, &rl);
    }
    std::vector<char*> argv;
    for (auto& a : all) argv.push_back(a.data());
    argv.push_back(nullptr);
    ::execv(argv[0], argv.data());
    ::_exit(127);
  }
  return pid;
}

}  // namespace ccfr::test
