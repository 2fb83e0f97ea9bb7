// The local backend (sweep_local.hpp): forks one `ccfr sweep run-cell` per cell, at most `jobs` at
// once, reports their frames as one progress and passes SIGINT and SIGTERM on to them.
#include "sweep_local.hpp"

#include <fcntl.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <spdlog/spdlog.h>
#include <algorithm>
#include <atomic>
#include <chrono>
#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>
#include <thread>

#include "ccfr/core/error.hpp"
#include "ccfr/io/output.hpp"
#include "ccfr/io/run_json.hpp"
#include "progress.hpp"
#include "sweep_cell.hpp"
#include "sweep_shell.hpp"

namespace ccfr::app {

namespace fs = std::filesystem;
using Json = nlohmann::ordered_json;

namespace {

// The signal that asked a sweep or ablation to stop (0 while none did); run_local passes it on.
std::atomic<int> g_sweep_signal{0};
extern "C" void on_sweep_signal(int sig) { g_sweep_signal = sig; }

// SIGINT and SIGTERM set g_sweep_signal while the cells run; the previous handlers come back after.
class SweepSignals {
 public:
  SweepSignals() {
    g_sweep_signal = 0;
    struct sigaction sa {};
    sa.sa_handler = on_sweep_signal;
    sigemptyset(&sa.sa_mask);
    ::sigaction(SIGINT, &sa, &int_);
    ::sigaction(SIGTERM, &sa, &term_);
  }
  ~SweepSignals() {
    ::sigaction(SIGINT, &int_, nullptr);
    ::sigaction(SIGTERM, &term_, nullptr);
  }
  SweepSignals(const SweepSignals&) = delete;
  SweepSignals& operator=(const SweepSignals&) = delete;

 private:
  struct sigaction int_ {
  }, term_{};
};

int hardware_threads() { return std::max(1u, std::thread::hardware_concurrency()); }

// Frames each cell of `indices` has in stats.csv already, at most its total: a resumed cell's
// frames are neither done nor to do in this call's progress, so that the ETA extrapolates from this
// session's speed only.
std::vector<long> frames_before(const SweepLayout& s, const std::vector<size_t>& indices,
                                const std::vector<long>& totals) {
  std::vector<long> before(indices.size());
  for (size_t k = 0; k < indices.size(); ++k)
    before[k] = std::min(frames_in_stats(s.dir / s.cells[indices[k]].id), totals[k]);
  return before;
}

// Frames this call runs: each cell's total less the frames it had run before.
long frames_to_run(const std::vector<long>& totals, const std::vector<long>& before) {
  long to_run = 0;
  for (size_t k = 0; k < totals.size(); ++k) to_run += totals[k] - before[k];
  return to_run;
}

// How cell i's attempt ended: its own record of it first (a run refused before it started leaves
// run.json as an earlier attempt wrote it), else run.json's status, else "no run".
std::string attempt_status(const SweepLayout& s, size_t i) {
  std::string status = "no run";
  const fs::path record = s.dir / "logs" / (s.cells[i].id + ".json");
  try {
    if (const Json r = read_json(record); r.is_object() && r.contains("status"))
      status = r["status"].get<std::string>();
    else if (io::is_ccfr_run(s.dir / s.cells[i].id))
      status = io::read_run_info(s.dir / s.cells[i].id).progress.status;
  } catch (const Error& e) {
    status = std::string("unreadable record: ") + e.what();
  }
  return status;
}

// One run_local call: the cells of `indices` as child processes, at most `jobs` at once, under one
// progress over the frames they run. Index k runs over `indices`, i over the sweep's cells.
class LocalRun {
 public:
  LocalRun(const SweepLayout& s, const std::vector<size_t>& indices, int jobs, int threads, const std::string& label)
      : s_(s),
        indices_(indices),
        jobs_(jobs),
        threads_(threads),
        label_(label),
        exe_(self_exe().string()),
        totals_(cell_frame_totals(s, indices)),
        before_(frames_before(s, indices, totals_)),
        done_frames_(indices.size(), 0),
        // ablate reports every frame; a sweep's many cells at most one line per 10 s (on a terminal, a bar).
        progress_(label + " frames", frames_to_run(totals_, before_), label == "ablate" ? 0.0 : 10.0) {}

  // Runs the cells, starting none after a stop signal, and waits for every running one; returns
  // the number that failed.
  int run();
  // The signal that stopped the cells (0: none came).
  int stopped_by() const { return stopping_; }

 private:
  struct Running {
    size_t k;
    std::chrono::steady_clock::time_point t0;
  };

  // Frames cell k has run in this call, from its stats.csv.
  long frames_now(size_t k) const {
    return std::clamp(frames_in_stats(s_.dir / s_.cells[indices_[k]].id) - before_[k], 0L, totals_[k] - before_[k]);
  }
  void report(bool force);
  void start_one();
  [[noreturn]] void exec_cell(size_t i, const fs::path& log, const sigset_t& previous) const;
  void pass_on_signal();
  bool finish_one(pid_t pid, int st);

  const SweepLayout& s_;
  const std::vector<size_t>& indices_;
  const int jobs_, threads_;
  const std::string& label_;
  const std::string exe_;
  const std::vector<long> totals_;  // frames each cell runs in all
  const std::vector<long> before_;  // frames each cell had run before this call
  std::vector<long> done_frames_;   // frames each cell has run in this call
  ProgressReporter progress_;
  std::map<pid_t, Running> running_;
  size_t next_ = 0, done_ = 0;  // cells started, cells ended
  int failed_ = 0, stopping_ = 0;
  long reported_ = -1;
  std::chrono::steady_clock::time_point last_draw_ = std::chrono::steady_clock::now();
};

// Updates the progress with the frames done over all cells and each running cell's frame: log
// lines only when the count moved (or `force`), a terminal's bar every second too.
void LocalRun::report(bool force) {
  long sum = 0;
  std::string cells;
  for (auto& [pid, r] : running_) {
    done_frames_[r.k] = frames_now(r.k);
    cells += (cells.empty() ? "" : ", ") + s_.cells[indices_[r.k]].id + " frame " +
             std::to_string(before_[r.k] + done_frames_[r.k]) + "/" + std::to_string(totals_[r.k]);
  }
  for (size_t k = 0; k < indices_.size(); ++k) sum += done_frames_[k];
  // A terminal's bar is redrawn every second so that its clock moves; log lines only on news.
  const auto now = std::chrono::steady_clock::now();
  const bool tick = progress_.on_terminal() && now - last_draw_ >= std::chrono::seconds(1);
  if ((sum == reported_ || sum == 0) && !force && !tick) return;
  reported_ = sum;
  last_draw_ = now;
  std::string detail = std::to_string(done_) + "/" + std::to_string(indices_.size()) + " cells done";
  if (failed_) detail += " (" + std::to_string(failed_) + " failed)";
  if (!cells.empty()) detail += "; " + cells;
  progress_.update(sum, detail);
}

// Starts the next cell as a child process `ccfr sweep run-cell DIR INDEX --threads N`.
void LocalRun::start_one() {
  const size_t k = next_++;
  const size_t i = indices_[k];
  const io::SweepCell& c = s_.cells[i];
  const fs::path log = s_.dir / "logs" / (c.id + ".log");
  // Blocked around fork so that a signal cannot reach the child before its exec (where this
  // process's handler would take it and exec would forget it): it stays pending until the child
  // has its default handling back, or is passed on once the child is in `running_`.
  sigset_t stop_set, previous;
  sigemptyset(&stop_set);
  sigaddset(&stop_set, SIGINT);
  sigaddset(&stop_set, SIGTERM);
  ::sigprocmask(SIG_BLOCK, &stop_set, &previous);
  const pid_t pid = fork();
  if (pid == 0) exec_cell(i, log, previous);
  if (pid > 0) running_[pid] = {k, std::chrono::steady_clock::now()};
  ::sigprocmask(SIG_SETMASK, &previous, nullptr);
  if (pid < 0) throw Error("cannot start a process for cell " + c.id);
  progress_.clear();
  spdlog::info("{}: started {} ({} of {}, {} threads)", label_, c.id, next_, indices_.size(), threads_);
}

// In the forked child: default SIGINT and SIGTERM handling and the signal mask `previous` back,
// stdout and stderr appended to `log`, then exec of run-cell for cell i (exit 127 if exec fails).
void LocalRun::exec_cell(size_t i, const fs::path& log, const sigset_t& previous) const {
  ::signal(SIGINT, SIG_DFL);
  ::signal(SIGTERM, SIG_DFL);
  ::sigprocmask(SIG_SETMASK, &previous, nullptr);
  // Appended: a resumed or rerun cell keeps the log of its earlier attempts above its own.
  const int fd = ::open(log.c_str(), O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0644);
  if (fd >= 0) ::dup2(fd, 1), ::dup2(fd, 2);
  const std::string dir = s_.dir.string(), idx = std::to_string(i), th = std::to_string(threads_);
  ::execl(exe_.c_str(), exe_.c_str(), "sweep", "run-cell", dir.c_str(), idx.c_str(), "--threads", th.c_str(),
          static_cast<char*>(nullptr));
  ::_exit(127);
}

// A signal to this process reaches every running cell (passed on here; Ctrl-C on a terminal
// reaches them directly too): each writes its checkpoint and status and stops; no cell starts after.
void LocalRun::pass_on_signal() {
  const int sig = g_sweep_signal.exchange(0);
  if (!sig) return;
  if (!stopping_) {
    progress_.clear();
    spdlog::warn(
        "{}: {} received: stopping the {} running cell(s) after their current frame (each writes its "
        "checkpoint); no further cell starts",
        label_, signal_name(sig), running_.size());
  }
  stopping_ = sig;
  for (const auto& [pid, r] : running_) ::kill(pid, sig);
}

// Records the end of child `pid` (wait status `st`) and logs how its cell ended; false when `pid`
// runs no cell of this call.
bool LocalRun::finish_one(pid_t pid, int st) {
  const auto it = running_.find(pid);
  if (it == running_.end()) return false;
  const auto [k, t0] = it->second;
  running_.erase(it);
  done_frames_[k] = frames_now(k);
  ++done_;
  const size_t i = indices_[k];
  const int code = WIFEXITED(st) ? WEXITSTATUS(st) : -1;
  const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const std::string status = attempt_status(s_, i);
  if (code != 0 && code != 3) ++failed_;
  progress_.clear();
  // A failed cell is worth a warning (shown under --quiet); its log says why.
  if (code != 0 && code != 3)
    spdlog::warn("{}: [{}/{}] {}: {} (exit {}) in {}; see {}", label_, done_, indices_.size(), s_.cells[i].id, status,
                 code, format_duration(secs), (s_.dir / "logs" / (s_.cells[i].id + ".log")).string());
  else
    spdlog::info("{}: [{}/{}] {}: {} (exit {}) in {}", label_, done_, indices_.size(), s_.cells[i].id, status, code,
                 format_duration(secs));
  return true;
}

int LocalRun::run() {
  // A signal during the set-up (loading every scene for the frame totals) starts no cell.
  while (next_ < indices_.size() && static_cast<int>(running_.size()) < jobs_ && !g_sweep_signal) start_one();
  while (!running_.empty()) {
    pass_on_signal();
    int st = 0;
    const pid_t pid = ::waitpid(-1, &st, WNOHANG);
    if (pid < 0) break;
    if (pid == 0) {
      report(false);
      std::this_thread::sleep_for(std::chrono::milliseconds(250));
      continue;
    }
    if (!finish_one(pid, st)) continue;
    if (next_ < indices_.size() && !stopping_) start_one();
    report(true);
  }
  progress_.finish();
  if (!stopping_) stopping_ = g_sweep_signal.exchange(0);
  return failed_;
}

}  // namespace

std::string signal_name(int sig) {
  return sig == SIGINT ? "SIGINT" : sig == SIGTERM ? "SIGTERM" : "signal " + std::to_string(sig);
}

int run_local(const SweepLayout& s, const std::vector<size_t>& indices, int jobs, int threads, const std::string& label,
              int* stopped_by) {
  SweepSignals signals;  // before the set-up: a signal while the scenes load starts no cell
  if (stopped_by) *stopped_by = 0;
  jobs = std::max(1, std::min<int>(jobs, static_cast<int>(indices.size())));
  if (threads <= 0) threads = std::max(1, hardware_threads() / jobs);
  LocalRun cells(s, indices, jobs, threads, label);
  const int failed = cells.run();
  if (stopped_by) *stopped_by = cells.stopped_by();
  return failed;
}

}  // namespace ccfr::app
