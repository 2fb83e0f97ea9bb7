// `ccfr sweep SPEC.yaml --out DIR` and its subcommands status, resume, collect and run-cell:
// grids of scene × contact solver × parameter values, run here (--backend local) or as one Slurm
// job array (--backend slurm), resumed from checkpoints, collected into one table. docs/cluster.md.
#include <fcntl.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <spdlog/spdlog.h>
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <thread>

#include "ccfr/core/error.hpp"
#include "ccfr/core/log.hpp"
#include "ccfr/io/checkpoint.hpp"
#include "ccfr/io/dir_lock.hpp"
#include "ccfr/io/obj.hpp"
#include "ccfr/io/output.hpp"
#include "ccfr/io/run_audit.hpp"
#include "ccfr/io/run_json.hpp"
#include "ccfr/io/scene_loader.hpp"
#include "ccfr/io/stats_csv.hpp"
#include "commands.hpp"
#include "frame_summary.hpp"
#include "progress.hpp"
#include "run_driver.hpp"
#include "sweep_runner.hpp"

namespace ccfr::app {

namespace fs = std::filesystem;
using Json = nlohmann::ordered_json;

namespace {

Json read_json(const fs::path& p) {
  std::ifstream in(p);
  if (!in) return Json();
  Json j = Json::parse(in, nullptr, false);
  return j.is_discarded() ? Json() : j;
}

// Output of a command run through the shell (sbatch, squeue, sacct), and its exit code.
std::pair<int, std::string> capture(const std::string& cmd) {
  std::string out;
  FILE* p = popen((cmd + " 2>&1").c_str(), "r");
  if (!p) return {-1, "popen failed"};
  char buf[4096];
  while (size_t n = fread(buf, 1, sizeof buf, p)) out.append(buf, n);
  const int st = pclose(p);
  return {WIFEXITED(st) ? WEXITSTATUS(st) : -1, out};
}

std::string quote(const std::string& a) {
  std::string o = "'";
  for (char c : a) o += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return o + "'";
}

fs::path self_exe() { return fs::read_symlink("/proc/self/exe"); }

// Array index list "0-3,7" of sorted indices.
std::string array_list(const std::vector<size_t>& idx) {
  std::string s;
  for (size_t i = 0; i < idx.size();) {
    size_t j = i;
    while (j + 1 < idx.size() && idx[j + 1] == idx[j] + 1) ++j;
    s += (s.empty() ? "" : ",") + std::to_string(idx[i]) + (j > i ? "-" + std::to_string(idx[j]) : "");
    i = j + 1;
  }
  return s;
}

int hardware_threads() { return std::max(1u, std::thread::hardware_concurrency()); }

}  // namespace

std::string fmt_num(double v, const char* f) {
  if (!std::isfinite(v)) return "";
  char b[64];
  std::snprintf(b, sizeof b, f, v);
  return b;
}

void write_sweep(const SweepLayout& s) {
  fs::create_directories(s.dir / "logs");
  const Json old = read_json(s.dir / "sweep.json");
  Json j;
  j["ccfr"] = {{"version", io::version()}, {"git_commit", io::git_commit()}};
  j["spec"] = s.spec.empty() ? Json(nullptr) : Json(s.spec.string());
  j["parameters"] = s.parameter_keys;
  j["audit_stride"] = s.audit_stride;
  if (s.cell_time_limit_s > 0.0) j["cell_time_limit_s"] = s.cell_time_limit_s;
  j["resources"] = {{"cpus_per_task", s.resources.cpus_per_task},
                    {"time", s.resources.time},
                    {"memory", s.resources.memory},
                    {"partition", s.resources.partition},
                    {"account", s.resources.account}};
  Json cells = Json::array();
  for (const auto& c : s.cells) {
    Json params = Json::object();
    for (const auto& [k, v] : c.params) params[k] = v;
    cells.push_back({{"id", c.id},
                     {"config", c.config.string()},
                     {"scene", c.scene},
                     {"solver", c.solver},
                     {"params", params},
                     {"overrides", c.overrides}});
  }
  j["cells"] = cells;
  j["slurm_jobs"] = old.is_object() && old.contains("slurm_jobs") ? old["slurm_jobs"] : Json::array();
  io::write_file_atomic(s.dir / "sweep.json", j.dump(2) + "\n");
}

SweepLayout read_sweep(const fs::path& dir) {
  const Json j = read_json(dir / "sweep.json");
  if (!j.is_object() || !j.contains("cells"))
    throw Error("'" + dir.string() + "' is not a sweep directory (no sweep.json written by ccfr sweep)");
  SweepLayout s;
  s.dir = dir;
  // at(), not operator[]: a const Json's operator[] on a missing key is undefined behaviour, and a
  // sweep.json edited by hand ({"cells": 5}) must be an error naming the file.
  try {
    s.spec = j.at("spec").is_string() ? fs::path(j.at("spec").get<std::string>()) : fs::path();
    s.parameter_keys = j.at("parameters").get<std::vector<std::string>>();
    s.audit_stride = j.at("audit_stride").get<int>();
    s.cell_time_limit_s = j.value("cell_time_limit_s", 0.0);  // absent in sweeps before it existed
    const Json& r = j.at("resources");
    s.resources = {r.at("cpus_per_task").get<int>(), r.at("time").get<std::string>(), r.at("memory").get<std::string>(),
                   r.at("partition").get<std::string>(), r.at("account").get<std::string>()};
    if (!j.at("cells").is_array()) throw Error("\"cells\" is not a list");
    for (const auto& c : j.at("cells")) {
      io::SweepCell cell;
      cell.id = c.at("id").get<std::string>();
      cell.config = c.at("config").get<std::string>();
      cell.scene = c.at("scene").get<std::string>();
      cell.solver = c.at("solver").get<std::string>();
      for (const auto& [k, v] : c.at("params").items()) cell.params.emplace_back(k, v.get<std::string>());
      cell.overrides = c.at("overrides").get<std::vector<std::string>>();
      s.cells.push_back(std::move(cell));
    }
  } catch (const Json::exception& e) {
    throw Error("'" + (dir / "sweep.json").string() + "' is damaged (not as ccfr sweep wrote it): " + e.what());
  } catch (const Error& e) {
    throw Error("'" + (dir / "sweep.json").string() + "' is damaged (not as ccfr sweep wrote it): " + e.what());
  }
  return s;
}

namespace {

/// DIR/logs/<id>.json: how the cell's last attempt ended (read by `sweep status`, the local runner
/// and `sweep collect`).
void write_cell_record(const fs::path& dir, const io::SweepCell& c, long index, int code, const std::string& status,
                       const std::string& verdict) {
  Json rec = {{"cell", c.id},
              {"index", index},
              {"exit_code", code},
              {"status", status},
              {"audit", verdict},
              {"host",
               [] {
                 char h[256] = "";
                 ::gethostname(h, sizeof h - 1);
                 return std::string(h);
               }()},
              {"end_time", io::utc_now()}};
  if (const char* job = std::getenv("SLURM_ARRAY_JOB_ID")) rec["slurm_job"] = job;
  if (const char* task = std::getenv("SLURM_ARRAY_TASK_ID")) rec["slurm_task"] = task;
  fs::create_directories(dir / "logs");
  io::write_file_atomic(dir / "logs" / (c.id + ".json"), rec.dump(2) + "\n");
}

// `ccfr sweep run-cell DIR INDEX`: what one array task (or one local job) does. Continues from the
// cell's checkpoint when it has one and has not completed, runs it from the start otherwise,
// audits the frames into audit.json and records the outcome in DIR/logs/<id>.json.
int run_cell(const fs::path& dir, long index, int threads) {
  const SweepLayout s = read_sweep(dir);
  if (index < 0 || index >= static_cast<long>(s.cells.size()))
    throw Error("cell index " + std::to_string(index) + " is outside the sweep's " + std::to_string(s.cells.size()) +
                " cells");
  const io::SweepCell& c = s.cells[static_cast<size_t>(index)];
  const fs::path out = dir / c.id;
  const std::string command =
      "ccfr sweep run-cell " + dir.string() + " " + std::to_string(index) + " (cell " + c.id + ")";
  // One writer per cell for the run, its audit and its record: a cell still running (its sweep
  // was killed, or a resume raced it) is refused here, naming the process that runs it.
  const io::DirLock lock = io::DirLock::acquire(out, command);
  // An earlier attempt's record would outlive this one if it ends without writing its own (killed).
  std::error_code gone;
  fs::remove(dir / "logs" / (c.id + ".json"), gone);
  RunOptions ro;
  ro.threads = threads;
  ro.time_limit_s = s.cell_time_limit_s;
  ro.progress = true;
  // The cell's earlier run counts only if it ran this cell's configuration: an ablation or sweep
  // rerun into the same directory with other --frames or --set starts the cell again instead of
  // reusing (or resuming) a run of the old one.
  std::string changed;
  bool completed = io::is_ccfr_run(out) && io::read_run_info(out).progress.status == "completed";
  if (completed) {
    const Json run = read_json(out / "run.json");
    try {
      changed =
          io::json_difference(run.value("config", Json()).dump(), io::load_scene(c.config, c.overrides).resolved_json);
    } catch (const Error&) {
      changed = "its scene no longer loads";  // the run below reports why
    }
    completed = changed.empty();
  } else if (const auto ck = io::is_ccfr_run(out) ? io::latest_checkpoint(out) : std::nullopt) {
    try {
      const io::Checkpoint k = io::read_checkpoint(*ck);
      if (k.overrides != c.overrides || k.scene_file != fs::absolute(c.config).lexically_normal())
        changed = "its checkpoint was written with other overrides or another scene file";
    } catch (const Error&) {
      // A damaged checkpoint: resuming reports it.
    }
  }
  if (!changed.empty())
    spdlog::info("sweep cell {} ({}): the run in {} is of another configuration ({}): running it again", index, c.id,
                 out.string(), changed);
  if (io::is_ccfr_run(out) && !completed && changed.empty() && io::latest_checkpoint(out)) {
    ro.resume = out;
  } else {
    ro.config = c.config;
    ro.overrides = c.overrides;
    ro.out = out;
  }
  ro.command_line = command;
  spdlog::info("sweep cell {} ({}): {}", index, c.id,
               completed           ? "completed earlier with this configuration; auditing its frames again"
               : ro.resume.empty() ? "from the start"
                                   : "resuming");
  int code = 0, stop_signal = 0;
  std::string status;
  if (completed) {
    status = "completed";
  } else {
    try {
      const RunSummary r = run_scene(ro);
      code = run_exit_code(r);
      status = r.status;
      stop_signal = r.stop_signal;
    } catch (const Error& e) {
      // Refused before or while running (a checkpoint of another build, a scene that no longer
      // loads): the record says so, not the status an earlier attempt left in run.json.
      write_cell_record(dir, c, index, 2, std::string("error: ") + e.what(), "not audited (the run did not start)");
      throw;
    }
  }
  // The audit of the frames written: pass, fail, or incomplete (clean frames of an unfinished run).
  // A cell stopped by a signal is not audited now: whoever stopped it wants it to end; `sweep
  // collect` audits it later.
  std::string verdict = stop_signal ? "not audited (stopped)" : "error";
  if (!stop_signal) {
    try {
      io::RunAuditOptions ao;
      ao.stride = s.audit_stride;
      const auto a = io::audit_run(out, ao);
      verdict = !a.clean() ? "fail" : a.completed() ? "pass" : "incomplete";
      const int acode = io::audit_exit_code(a, verdict);
      io::write_file_atomic(out / "audit.json", io::audit_report_json(a, verdict, acode, verdict == "incomplete"));
    } catch (const Error& e) {
      spdlog::error("sweep cell {}: audit failed: {}", c.id, e.what());
    }
  }
  write_cell_record(dir, c, index, code, status, verdict);
  return code;
}

}  // namespace

long frames_in_stats(const fs::path& run_dir) {
  std::ifstream in(run_dir / "stats.csv", std::ios::binary);
  if (!in) return 0;
  long lines = 0;
  char buf[1 << 14];
  while (in.read(buf, sizeof buf) || in.gcount() > 0) lines += std::count(buf, buf + in.gcount(), '\n');
  return std::max(0L, lines - 1);  // the header
}

std::vector<long> cell_frame_totals(const SweepLayout& s, const std::vector<size_t>& indices) {
  std::map<std::pair<std::string, std::vector<std::string>>, long> loaded;
  std::vector<long> totals;
  for (size_t i : indices) {
    const io::SweepCell& c = s.cells[i];
    long n = -1;
    for (const auto& o : c.overrides)
      if (o.rfind("time.frames=", 0) == 0) n = std::strtol(o.c_str() + 12, nullptr, 10);
    if (n < 0) {
      // No override: the scene's own time.frames (the resolved config holds the default too). The
      // scene is loaded once per config (and time overrides), not once per cell.
      std::vector<std::string> time_overrides;
      for (const auto& o : c.overrides)
        if (o.rfind("time", 0) == 0) time_overrides.push_back(o);
      const auto key = std::make_pair(c.config.string(), time_overrides);
      auto it = loaded.find(key);
      if (it == loaded.end()) {
        long f = 0;
        try {
          f = Json::parse(io::load_scene(c.config, time_overrides).resolved_json)["time"]["frames"].get<long>();
        } catch (const std::exception&) {
          // The cell will fail with this error itself; it adds no frames to the progress.
        }
        it = loaded.emplace(key, f).first;
      }
      n = it->second;
    }
    totals.push_back(std::max(0L, n));
  }
  return totals;
}

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
}  // namespace

std::string signal_name(int sig) {
  return sig == SIGINT ? "SIGINT" : sig == SIGTERM ? "SIGTERM" : "signal " + std::to_string(sig);
}

int run_local(const SweepLayout& s, const std::vector<size_t>& indices, int jobs, int threads, const std::string& label,
              int* stopped_by) {
  SweepSignals signals;
  int stopping = 0;
  if (stopped_by) *stopped_by = 0;
  jobs = std::max(1, std::min<int>(jobs, static_cast<int>(indices.size())));
  if (threads <= 0) threads = std::max(1, hardware_threads() / jobs);
  const std::string exe = self_exe().string();
  // Progress counts the frames this call runs: a resumed cell's frames already in stats.csv are
  // neither done nor to do, so that the ETA extrapolates from this session's speed only.
  const std::vector<long> totals = cell_frame_totals(s, indices);
  std::vector<long> before(indices.size()), done_frames(indices.size(), 0);
  long to_run = 0;
  for (size_t k = 0; k < indices.size(); ++k) {
    before[k] = std::min(frames_in_stats(s.dir / s.cells[indices[k]].id), totals[k]);
    to_run += totals[k] - before[k];
  }
  auto frames_now = [&](size_t k) {
    return std::clamp(frames_in_stats(s.dir / s.cells[indices[k]].id) - before[k], 0L, totals[k] - before[k]);
  };
  // ablate reports every frame; a sweep's many cells at most one line per 10 s (on a terminal, a bar).
  ProgressReporter progress(label + " frames", to_run, label == "ablate" ? 0.0 : 10.0);
  struct Running {
    size_t k;
    std::chrono::steady_clock::time_point t0;
  };
  std::map<pid_t, Running> running;
  size_t next = 0, done = 0;
  int failed = 0;
  long reported = -1;
  auto last_draw = std::chrono::steady_clock::now();
  auto report = [&](bool force) {
    long sum = 0;
    std::string cells;
    for (auto& [pid, r] : running) {
      done_frames[r.k] = frames_now(r.k);
      cells += (cells.empty() ? "" : ", ") + s.cells[indices[r.k]].id + " frame " +
               std::to_string(before[r.k] + done_frames[r.k]) + "/" + std::to_string(totals[r.k]);
    }
    for (size_t k = 0; k < indices.size(); ++k) sum += done_frames[k];
    // A terminal's bar is redrawn every second so that its clock moves; log lines only on news.
    const auto now = std::chrono::steady_clock::now();
    const bool tick = progress.on_terminal() && now - last_draw >= std::chrono::seconds(1);
    if ((sum == reported || sum == 0) && !force && !tick) return;
    reported = sum;
    last_draw = now;
    std::string detail = std::to_string(done) + "/" + std::to_string(indices.size()) + " cells done";
    if (failed) detail += " (" + std::to_string(failed) + " failed)";
    if (!cells.empty()) detail += "; " + cells;
    progress.update(sum, detail);
  };
  // A signal to this process reaches every running cell (passed on below; Ctrl-C on a terminal
  // reaches them directly too): each writes its checkpoint and status and stops.
  auto start_one = [&] {
    const size_t k = next++;
    const size_t i = indices[k];
    const io::SweepCell& c = s.cells[i];
    const fs::path log = s.dir / "logs" / (c.id + ".log");
    // Blocked around fork so that a signal cannot reach the child before its exec (where this
    // process's handler would take it and exec would forget it): it stays pending until the child
    // has its default handling back, or is passed on once the child is in `running`.
    sigset_t stop_set, previous;
    sigemptyset(&stop_set);
    sigaddset(&stop_set, SIGINT);
    sigaddset(&stop_set, SIGTERM);
    ::sigprocmask(SIG_BLOCK, &stop_set, &previous);
    const pid_t pid = fork();
    if (pid == 0) {
      ::signal(SIGINT, SIG_DFL);
      ::signal(SIGTERM, SIG_DFL);
      ::sigprocmask(SIG_SETMASK, &previous, nullptr);
      // Appended: a resumed or rerun cell keeps the log of its earlier attempts above its own.
      const int fd = ::open(log.c_str(), O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0644);
      if (fd >= 0) ::dup2(fd, 1), ::dup2(fd, 2);
      const std::string dir = s.dir.string(), idx = std::to_string(i), th = std::to_string(threads);
      ::execl(exe.c_str(), exe.c_str(), "sweep", "run-cell", dir.c_str(), idx.c_str(), "--threads", th.c_str(),
              static_cast<char*>(nullptr));
      ::_exit(127);
    }
    if (pid > 0) running[pid] = {k, std::chrono::steady_clock::now()};
    ::sigprocmask(SIG_SETMASK, &previous, nullptr);
    if (pid < 0) throw Error("cannot start a process for cell " + c.id);
    progress.clear();
    spdlog::info("{}: started {} ({} of {}, {} threads)", label, c.id, next, indices.size(), threads);
  };
  // A signal during the set-up above (loading every scene for the frame totals) starts no cell.
  while (next < indices.size() && static_cast<int>(running.size()) < jobs && !g_sweep_signal) start_one();
  while (!running.empty()) {
    if (const int sig = g_sweep_signal.exchange(0)) {
      if (!stopping) {
        progress.clear();
        spdlog::warn(
            "{}: {} received: stopping the {} running cell(s) after their current frame (each writes its "
            "checkpoint); no further cell starts",
            label, signal_name(sig), running.size());
      }
      stopping = sig;
      for (const auto& [pid, r] : running) ::kill(pid, sig);
    }
    int st = 0;
    const pid_t pid = ::waitpid(-1, &st, WNOHANG);
    if (pid < 0) break;
    if (pid == 0) {
      report(false);
      std::this_thread::sleep_for(std::chrono::milliseconds(250));
      continue;
    }
    const auto it = running.find(pid);
    if (it == running.end()) continue;
    const auto [k, t0] = it->second;
    running.erase(it);
    done_frames[k] = frames_now(k);
    ++done;
    const size_t i = indices[k];
    const int code = WIFEXITED(st) ? WEXITSTATUS(st) : -1;
    const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    // The cell's own record of this attempt first: a run refused before it started leaves run.json
    // as an earlier attempt wrote it.
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
    if (code != 0 && code != 3) ++failed;
    progress.clear();
    // A failed cell is worth a warning (shown under --quiet); its log says why.
    if (code != 0 && code != 3)
      spdlog::warn("{}: [{}/{}] {}: {} (exit {}) in {}; see {}", label, done, indices.size(), s.cells[i].id, status,
                   code, format_duration(secs), (s.dir / "logs" / (s.cells[i].id + ".log")).string());
    else
      spdlog::info("{}: [{}/{}] {}: {} (exit {}) in {}", label, done, indices.size(), s.cells[i].id, status, code,
                   format_duration(secs));
    if (next < indices.size() && !stopping) start_one();
    report(true);
  }
  progress.finish();
  if (!stopping) stopping = g_sweep_signal.exchange(0);
  if (stopped_by) *stopped_by = stopping;
  return failed;
}

namespace {

// ---- Slurm ----------------------------------------------------------------------------------

struct SlurmFlags {
  int cpus = -1;
  std::string time, memory, partition, account;
  std::string sbatch = "sbatch";
};

void apply_flags(io::SweepResources& r, const SlurmFlags& f) {
  if (f.cpus > 0) r.cpus_per_task = f.cpus;
  if (!f.time.empty()) r.time = f.time;
  if (!f.memory.empty()) r.memory = f.memory;
  if (!f.partition.empty()) r.partition = f.partition;
  if (!f.account.empty()) r.account = f.account;
}

// Slurm refuses array indices at or above its MaxArraySize: the cluster's (scontrol show config),
// else Slurm's default 1001. Throws naming both before anything is written or submitted.
void check_slurm_array_size(const SweepLayout& s, const std::vector<size_t>& indices) {
  if (indices.empty()) return;
  long max_array = 1001;
  std::string source = "Slurm's default; `scontrol show config` did not say";
  const auto [code, out] = capture("scontrol show config");
  if (const size_t at = out.find("MaxArraySize"); code == 0 && at != std::string::npos) {
    const size_t eq = out.find('=', at);
    if (eq != std::string::npos) {
      const long v = std::strtol(out.c_str() + eq + 1, nullptr, 10);
      if (v > 0) max_array = v, source = "`scontrol show config`";
    }
  }
  if (static_cast<long>(indices.back()) < max_array) return;
  throw Error("the sweep's array would need task index " + std::to_string(indices.back()) + " (" +
              std::to_string(s.cells.size()) + " cells), but Slurm's MaxArraySize is " + std::to_string(max_array) +
              " (" + source + "): sbatch would refuse it; split the grid into specs of at most " +
              std::to_string(max_array) + " cells (docs/cluster.md)");
}

// Writes DIR/sweep.sbatch (one array task per cell) and submits `indices` of it; records the job.
std::string slurm_submit(const SweepLayout& s, const std::vector<size_t>& indices, const std::string& sbatch) {
  check_slurm_array_size(s, indices);
  const fs::path dir = fs::absolute(s.dir).lexically_normal();
  const auto& r = s.resources;
  std::string sh =
      "#!/bin/bash\n# Written by ccfr sweep: one array task per cell of " + dir.string() +
      "/sweep.json.\n#SBATCH --job-name=ccfr-sweep\n#SBATCH --cpus-per-task=" + std::to_string(r.cpus_per_task) + "\n";
  if (!r.time.empty()) sh += "#SBATCH --time=" + r.time + "\n";
  if (!r.memory.empty()) sh += "#SBATCH --mem=" + r.memory + "\n";
  if (!r.partition.empty()) sh += "#SBATCH --partition=" + r.partition + "\n";
  if (!r.account.empty()) sh += "#SBATCH --account=" + r.account + "\n";
  sh += "#SBATCH --output=" + (dir / "logs" / "slurm-%A_%a.out").string() + "\n#SBATCH --chdir=" + dir.string() +
        "\n# SIGTERM (scancel, the time limit) makes the cell write a checkpoint; `ccfr sweep resume` continues it.\n" +
        "exec " + quote(self_exe().string()) + " sweep run-cell " + quote(dir.string()) +
        " \"$SLURM_ARRAY_TASK_ID\" --threads \"${SLURM_CPUS_PER_TASK:-1}\"\n";
  const fs::path script = dir / "sweep.sbatch";
  io::write_file_atomic(script, sh);
  fs::permissions(script, fs::perms::owner_exec, fs::perm_options::add);
  const std::string array = array_list(indices);
  const auto [code, out] = capture(sbatch + " --parsable --array=" + array + " " + quote(script.string()));
  if (code != 0) throw Error("sbatch failed (exit " + std::to_string(code) + "): " + out);
  std::string job = out.substr(0, out.find_first_of(";\n"));
  if (job.empty() || job.find_first_not_of("0123456789") != std::string::npos)
    throw Error("sbatch printed no job id: '" + out + "'");
  Json j = read_json(dir / "sweep.json");
  j["slurm_jobs"].push_back({{"job_id", job}, {"array", array}, {"submitted", io::utc_now()}});
  io::write_file_atomic(dir / "sweep.json", j.dump(2) + "\n");
  std::printf("sweep: submitted job %s (array %s, %zu cells) with %s; `ccfr sweep status %s` follows it\n", job.c_str(),
              array.c_str(), indices.size(), script.string().c_str(), dir.string().c_str());
  return job;
}

// Why squeue may have failed, for its messages: most often the cluster's SLURM_CONF is not set in
// this shell (scripts/slurm-local prints the line that sets it).
std::string slurm_conf_hint() {
  const char* conf = std::getenv("SLURM_CONF");
  if (!conf || !*conf)
    return "SLURM_CONF is not set: set it as for the sbatch that submitted the sweep, e.g. "
           "eval \"$(scripts/slurm-local env)\" for the single-machine cluster";
  return std::string("SLURM_CONF is ") + conf + ": is that cluster running?";
}

// Slurm's view of the sweep's array tasks: cell index -> state (PENDING, RUNNING, COMPLETED,
// CANCELLED, TIMEOUT, FAILED, ...) of its latest job; squeue for live tasks, sacct when accounting
// is available (without it sacct fails and only run.json tells).
std::map<size_t, std::string> slurm_states(const fs::path& dir, bool* queue_known = nullptr) {
  std::map<size_t, std::string> st;
  const Json j = read_json(dir / "sweep.json");
  if (!j.is_object() || !j.contains("slurm_jobs") || !j.at("slurm_jobs").is_array() || j.at("slurm_jobs").empty())
    return st;
  std::string ids;
  for (const auto& job : j.at("slurm_jobs"))
    if (job.is_object() && job.contains("job_id") && job.at("job_id").is_string())
      ids += (ids.empty() ? "" : ",") + job.at("job_id").get<std::string>();
  auto parse = [&](const std::string& text, char sep) {
    std::istringstream in(text);
    for (std::string line; std::getline(in, line);) {
      const size_t us = line.find('_'), sp = line.find(sep);
      if (us == std::string::npos || sp == std::string::npos || sp < us) continue;
      const std::string task = line.substr(us + 1, sp - us - 1);
      if (task.empty() || task.find_first_not_of("0123456789") != std::string::npos) continue;
      std::string state = line.substr(sp + 1);
      state = state.substr(0, state.find_first_of(" \t"));
      st[std::stoul(task)] = state;  // later jobs come later: the latest state wins
    }
  };
  const auto [sc, sacct] = capture("sacct -n -P -X -j " + ids + " -o JobID,State");
  if (sc == 0) parse(sacct, '|');
  const auto [qc, squeue] = capture("squeue -h -r -j " + ids + " -o '%i %T'");
  if (queue_known) *queue_known = qc == 0;
  if (qc == 0)
    parse(squeue, ' ');
  else  // e.g. SLURM_CONF not set as for sbatch: queued cells would look not started, running ones lost
    spdlog::warn("sweep: squeue failed (exit {}): {}; queued and running cells are not known as such ({})", qc,
                 squeue.substr(0, squeue.find('\n')), slurm_conf_hint());
  return st;
}

// What a cell is now: queued / running (Slurm), completed, or why it stopped.
std::string cell_state(const SweepLayout& s, size_t i, const std::map<size_t, std::string>& slurm) {
  const auto it = slurm.find(i);
  if (it != slurm.end() && (it->second == "PENDING" || it->second == "RUNNING" || it->second == "CONFIGURING" ||
                            it->second == "COMPLETING" || it->second == "REQUEUED"))
    return it->second == "PENDING" ? "queued" : "running";
  const fs::path out = s.dir / s.cells[i].id;
  // A live process holds the cell's lock: it runs, whatever run.json says (its sweep may be gone).
  if (io::lock_holder(out)) return "running";
  if (!io::is_ccfr_run(out)) return it != slurm.end() ? "lost (" + it->second + ", no run)" : "not started";
  const std::string status = io::read_run_info(out).progress.status;
  if (status == "completed") return "completed";
  if (it != slurm.end() && it->second.rfind("CANCELLED", 0) == 0) return "cancelled";
  if (it != slurm.end() && it->second == "TIMEOUT") return "timeout";
  if (status.rfind("terminated", 0) == 0) return "terminated";
  if (status.rfind("interrupted", 0) == 0) return "interrupted";
  if (status.rfind("stopped at its time limit", 0) == 0) return "timeout";  // the spec's cell_time_limit
  if (status.rfind("failed", 0) == 0) return "failed";
  return "lost";  // run.json says running but nothing runs it: the node or process died
}

bool resumable(const std::string& state) { return state != "completed" && state != "queued" && state != "running"; }

}  // namespace

// ---- collect ----------------------------------------------------------------------------------

std::vector<CellRow> collect_rows(const SweepLayout& s) {
  std::vector<CellRow> rows;
  for (const auto& c : s.cells) {
    CellRow r;
    r.id = c.id;
    r.scene = c.scene;
    r.solver = c.solver;
    for (const auto& [k, v] : c.params) r.values.push_back(v);
    const fs::path out = s.dir / c.id;
    if (!io::is_ccfr_run(out)) {
      r.status = "not run";
      r.audit = "";
      rows.push_back(r);
      continue;
    }
    const Json run = read_json(out / "run.json");
    r.status = run.value("status", std::string());
    if (r.solver.empty()) r.solver = run.value("solver", std::string());
    // stats.csv, by column name (kStatsColumns): a run of an older ccfr may lack the newer columns.
    const io::StatsCsv stats = io::read_stats_csv(out / "stats.csv");
    const bool has_lag = stats.has(stats_column("lag_mean")) && stats.has(stats_column("lag_max"));
    const bool has_cpu = stats.has(stats_column("cpu_s")), has_iterations = stats.has(stats_column("outer_iterations"));
    const std::vector<FrameStats>& fsv = stats.rows;
    r.frames = fsv.size();
    if (!fsv.empty()) {
      const auto wall = aggregate(fsv, [](const FrameStats& f) { return f.wall_s; });
      r.avg_s = wall.mean, r.max_s = wall.max, r.median_s = wall.median;
      r.xpbd = aggregate(fsv, [](const FrameStats& f) { return f.times.xpbd; }).mean;
      r.broad = aggregate(fsv, [](const FrameStats& f) { return f.times.broad; }).mean;
      r.narrow = aggregate(fsv, [](const FrameStats& f) { return f.times.narrow; }).mean;
      r.resolution = aggregate(fsv, [](const FrameStats& f) { return f.times.resolution; }).mean;
      if (has_lag) {
        r.lag_mean = aggregate(fsv, [](const FrameStats& f) { return f.lag_mean; }).mean;
        r.lag_max = aggregate(fsv, [](const FrameStats& f) { return f.lag_max; }).max;
      }
      if (has_cpu) r.cpu_s = aggregate(fsv, [](const FrameStats& f) { return f.cpu_s; }).mean;
      if (has_iterations)
        r.outer_iterations =
            aggregate(fsv, [](const FrameStats& f) { return static_cast<double>(f.outer_iterations); }).mean;
    }
    for (const auto& f : fsv) {
      r.detected += f.violations_detected;
      r.remaining_sum += f.violations_remaining;
      r.remaining_max = std::max<long>(r.remaining_max, f.violations_remaining);
      r.halted += f.halted_vertices;
      r.contact_vertices += f.contact_vertices;
    }
    // The audit: the cell's own (run-cell writes it), or one made now.
    Json audit = read_json(out / "audit.json");
    const bool stale = !audit.is_object() || audit.value("frames_total", -1L) != run.value("frames_written", -2L) ||
                       audit.value("status", Json()).dump() != Json(r.status).dump();
    if (stale) {
      try {
        io::RunAuditOptions ao;
        ao.stride = s.audit_stride;
        const auto a = io::audit_run(out, ao);
        const std::string verdict = !a.clean() ? "fail" : a.completed() ? "pass" : "incomplete";
        const std::string text =
            io::audit_report_json(a, verdict, io::audit_exit_code(a, verdict), verdict == "incomplete");
        io::write_file_atomic(out / "audit.json", text);
        audit = Json::parse(text);
      } catch (const Error& e) {
        spdlog::error("sweep collect: audit of {} failed: {}", out.string(), e.what());
        audit = Json{{"verdict", "error"}};
      }
    }
    r.audit = audit.value("verdict", std::string("error"));
    r.audit_violations = audit.value("violations", 0L);
    const double md =
        audit.contains("min_distance") && audit["min_distance"].is_number() ? audit["min_distance"].get<double>() : NAN;
    const double off = audit.contains("offset") && audit["offset"].is_number() ? audit["offset"].get<double>() : NAN;
    r.min_over_xi = md / off;
    std::map<long, long> pen;
    if (audit.contains("frames"))
      for (const auto& f : audit["frames"])
        pen[f["frame"].get<long>()] =
            f["triangle_intersections"].get<long>() + f["segment_crossings"].get<long>() + f["close_pairs"].get<long>();
    for (const auto& f : fsv) {
      const auto it = pen.find(f.frame);
      r.per_frame.push_back({f.frame, f.violations_detected, f.violations_remaining, f.halted_vertices,
                             f.contact_vertices, it != pen.end() ? it->second : -1});
    }
    rows.push_back(std::move(r));
  }
  return rows;
}

std::string metrics_header() {
  return "frames,status,avg_frame_s,max_frame_s,median_frame_s,xpbd_s,broad_s,narrow_s,resolution_s,violations_"
         "detected,"
         "violations_remaining,max_violations_remaining,halted_vertices,audit,audit_violations,min_distance_over_"
         "offset,lag_mean,lag_max,cpu_frame_s,outer_iterations";
}

std::string metrics_csv(const CellRow& r) {
  std::string status = r.status;
  std::replace(status.begin(), status.end(), ',', ';');
  return std::to_string(r.frames) + "," + status + "," + fmt_num(r.avg_s) + "," + fmt_num(r.max_s) + "," +
         fmt_num(r.median_s) + "," + fmt_num(r.xpbd) + "," + fmt_num(r.broad) + "," + fmt_num(r.narrow) + "," +
         fmt_num(r.resolution) + "," + std::to_string(r.detected) + "," + std::to_string(r.remaining_sum) + "," +
         std::to_string(r.remaining_max) + "," + std::to_string(r.halted) + "," + r.audit + "," +
         std::to_string(r.audit_violations) + "," + fmt_num(r.min_over_xi, "%.9f") + "," + fmt_num(r.lag_mean, "%.6g") +
         "," + fmt_num(r.lag_max, "%.6g") + "," + fmt_num(r.cpu_s, "%.6f") + "," + fmt_num(r.outer_iterations, "%.3f");
}

namespace {

int collect(const fs::path& dir, const std::string& metric, const std::string& against, bool plot) {
  const auto t0 = std::chrono::steady_clock::now();
  const SweepLayout s = read_sweep(dir);
  const auto rows = collect_rows(s);
  std::string head = "cell,scene,solver";
  for (const auto& k : s.parameter_keys) head += "," + k;
  std::string csv = head + ",halting_percent," + metrics_header() + "\n";
  std::string md = "# Sweep `" + dir.filename().string() + "`\n\n" + std::to_string(rows.size()) +
                   " cells; every run audited with the exact audit (`ccfr audit`, stride " +
                   std::to_string(s.audit_stride) + "). Times are mean seconds per frame.\n\n| scene | solver |";
  for (const auto& k : s.parameter_keys) md += " `" + k + "` |";
  md +=
      " status | frames | mean s/frame | max s/frame | XPBD | broad | narrow | resolution | violations detected | "
      "remaining (sum / max) | halted (%) | audit | min dist / ξ |\n|---|---|";
  for (size_t k = 0; k < s.parameter_keys.size(); ++k) md += "---|";
  md += "---|---|---|---|---|---|---|---|---|---|---|---|---|\n";
  for (const auto& r : rows) {
    const double halting = r.contact_vertices > 0 ? 100.0 * r.halted / r.contact_vertices : NAN;
    csv += r.id + "," + r.scene + "," + r.solver;
    for (const auto& v : r.values) csv += "," + v;
    csv += "," + fmt_num(halting, "%.4f") + "," + metrics_csv(r) + "\n";
    md += "| " + r.scene + " | `" + r.solver + "` |";
    for (const auto& v : r.values) md += " " + v + " |";
    std::string status = r.status;
    std::replace(status.begin(), status.end(), '|', '/');
    md += " " + status + " | " + std::to_string(r.frames) + " | " + fmt_num(r.avg_s, "%.4f") + " | " +
          fmt_num(r.max_s, "%.4f") + " | " + fmt_num(r.xpbd, "%.4f") + " | " + fmt_num(r.broad, "%.4f") + " | " +
          fmt_num(r.narrow, "%.4f") + " | " + fmt_num(r.resolution, "%.4f") + " | " + std::to_string(r.detected) +
          " | " + std::to_string(r.remaining_sum) + " / " + std::to_string(r.remaining_max) + " | " +
          std::to_string(r.halted) + (std::isfinite(halting) ? " (" + fmt_num(halting, "%.2f") + ")" : "") + " | " +
          r.audit + (r.audit == "fail" ? " (" + std::to_string(r.audit_violations) + ")" : "") + " | " +
          fmt_num(r.min_over_xi, "%.4f") + " |\n";
  }
  io::write_file_atomic(dir / "sweep.csv", csv);
  io::write_file_atomic(dir / "sweep.md", md);
  std::fputs(md.c_str(), stdout);
  if (plot) {
    const std::string x = against.empty() && !s.parameter_keys.empty() ? s.parameter_keys.front() : against;
    const fs::path script = fs::path(CCFR_SOURCE_DIR) / "scripts" / "plot_sweep.py";
    if (!x.empty() && fs::exists(script) && fs::exists("/usr/bin/python3")) {
      const std::string cmd = "/usr/bin/python3 " + quote(script.string()) + " " + quote((dir / "sweep.csv").string()) +
                              " --metric " + quote(metric) + " --against " + quote(x) + " > /dev/null 2>&1";
      if (std::system(cmd.c_str()) != 0)
        spdlog::warn("sweep collect: plotting failed ({}); the tables are written", cmd);
    }
  }
  size_t bad = 0, unfinished = 0;
  const CellRow* failing = nullptr;
  for (const auto& r : rows) {
    bad += r.audit != "pass";
    unfinished += r.status != "completed";
    if (!failing && r.status == "completed" && r.audit != "pass") failing = &r;
  }
  if (bad)
    std::fprintf(stderr, "sweep collect: %zu of %zu cells did not pass the audit or did not complete\n", bad,
                 rows.size());
  // Cells not completed are continued first; then a completed cell that failed its audit is looked
  // at in its own report; with every cell passing, the pictures of the first.
  const std::string next = unfinished     ? "ccfr sweep resume " + shell_quote(dir.string())
                           : failing      ? "ccfr audit " + shell_quote((dir / failing->id).string())
                           : rows.empty() ? "ccfr sweep status " + shell_quote(dir.string())
                                          : "ccfr render " + shell_quote((dir / rows.front().id).string()) + " --sheet";
  const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::printf("\nsweep collect: %zu cells, %zu passed the audit, %zu not completed, in %s; tables in %s; next: %s\n",
              rows.size(), rows.size() - bad, unfinished, format_duration(secs).c_str(),
              (dir / "sweep.md").string().c_str(), next.c_str());
  return bad ? 1 : 0;
}

struct SweepOptions {
  fs::path spec, out;
  std::string backend = "local";
  int jobs = 1, threads = 0;
  SlurmFlags slurm;
  fs::path dir;  // subcommands
  long index = -1;
  std::string metric = "avg_frame_s", against;
  bool plot = true;
};

// Runs the cells here, then the closing summary on stdout: cells by outcome, frames, time.
int run_and_summarize(const SweepLayout& s, const std::vector<size_t>& indices, int jobs, int threads) {
  const auto t0 = std::chrono::steady_clock::now();
  int stopped_by = 0;
  const int failed = run_local(s, indices, jobs, threads, "sweep", &stopped_by);
  const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  long frames = 0;
  for (size_t i : indices) frames += frames_in_stats(s.dir / s.cells[i].id);
  if (stopped_by) {
    std::printf(
        "sweep: stopped by %s after %s (%ld frames in all): the running cells wrote their checkpoints; "
        "next: ccfr sweep resume %s\n",
        signal_name(stopped_by).c_str(), format_duration(secs).c_str(), frames, s.dir.string().c_str());
    return interrupted_exit_code(stopped_by);
  }
  std::printf("sweep: %zu cells run, %d failed, in %s (%ld frames in all); next: ccfr sweep collect %s\n",
              indices.size(), failed, format_duration(secs).c_str(), frames, s.dir.string().c_str());
  return failed ? 1 : 0;
}

int start_sweep(SweepOptions& o) {
  io::SweepSpec spec = io::load_sweep_spec(o.spec);
  SweepLayout s{o.out,          spec.cells, spec.parameter_keys,   spec.audit_stride,
                spec.resources, spec.file,  spec.cell_time_limit_s};
  apply_flags(s.resources, o.slurm);
  // One sweep process per sweep directory (its cells are locked apart by their run-cell).
  const io::DirLock lock = io::DirLock::acquire(o.out, invocation_string());
  if (fs::exists(o.out / "sweep.json")) {
    const SweepLayout old = read_sweep(o.out);
    std::vector<std::string> a, b;
    for (const auto& c : old.cells) a.push_back(c.id);
    for (const auto& c : s.cells) b.push_back(c.id);
    if (a != b)
      throw Error("'" + o.out.string() +
                  "' holds another sweep (its cells differ); choose another --out, or use `ccfr "
                  "sweep resume`");
  } else if (!io::dir_is_empty(o.out)) {
    throw Error("output directory '" + o.out.string() + "' is not empty and is not a sweep; choose another --out");
  }
  std::vector<size_t> all(s.cells.size());
  for (size_t i = 0; i < all.size(); ++i) all[i] = i;
  if (o.backend == "slurm") check_slurm_array_size(s, all);  // before the sweep's folder is written
  write_sweep(s);
  spdlog::info("sweep: {} cells in {}", all.size(), o.out.string());
  if (o.backend == "slurm") {
    slurm_submit(s, all, o.slurm.sbatch);
    return 0;
  }
  return run_and_summarize(s, all, o.jobs, o.threads);
}

int sweep_status(const fs::path& dir) {
  const SweepLayout s = read_sweep(dir);
  const auto slurm = slurm_states(dir);
  std::vector<size_t> all(s.cells.size());
  for (size_t i = 0; i < all.size(); ++i) all[i] = i;
  const std::vector<long> totals = cell_frame_totals(s, all);
  std::map<std::string, int> counts;
  long done = 0, total = 0;
  std::printf("%-60s %-14s %s\n", "cell", "state", "frames (latest checkpoint)");
  for (size_t i = 0; i < s.cells.size(); ++i) {
    const std::string st = cell_state(s, i, slurm);
    ++counts[st.substr(0, st.find(" ("))];  // "lost (CANCELLED, no run)" counts as lost; "not started" whole
    const fs::path out = dir / s.cells[i].id;
    const long n = std::min(frames_in_stats(out), totals[i]);
    done += n;
    total += totals[i];
    std::string frames = std::to_string(n) + "/" + std::to_string(totals[i]);
    if (const auto ck = io::is_ccfr_run(out) ? io::latest_checkpoint(out) : std::nullopt)
      frames += " (" + ck->filename().string() + ")";
    std::printf("%-60s %-14s %s\n", s.cells[i].id.c_str(), st.c_str(), frames.c_str());
  }
  std::string summary;
  for (const auto& [k, n] : counts) summary += (summary.empty() ? "" : ", ") + std::to_string(n) + " " + k;
  std::printf("%zu cells: %s\n", s.cells.size(), summary.c_str());
  std::printf("frames: %ld of %ld (%.0f %%)\n", done, total, total > 0 ? 100.0 * done / total : 100.0);
  // Every cell done: collect; some still running or queued: look again; otherwise resume the rest.
  const std::string d = shell_quote(dir.string());
  const bool waiting = counts.count("running") > 0 || counts.count("queued") > 0;
  std::printf("next: %s\n", counts["completed"] == static_cast<int>(s.cells.size())
                                ? ("ccfr sweep collect " + d).c_str()
                            : waiting ? ("ccfr sweep status " + d).c_str()
                                      : ("ccfr sweep resume " + d).c_str());
  return 0;
}

int resume(SweepOptions& o) {
  SweepLayout s = read_sweep(o.dir);
  const io::DirLock lock = io::DirLock::acquire(o.dir, invocation_string());
  apply_flags(s.resources, o.slurm);
  const Json j = read_json(o.dir / "sweep.json");
  const bool slurm_sweep =
      o.backend == "slurm" || (o.backend.empty() && j.contains("slurm_jobs") && !j.at("slurm_jobs").empty());
  bool queue_known = true;
  const auto states = slurm_states(o.dir, &queue_known);
  std::vector<size_t> to_resume;
  for (size_t i = 0; i < s.cells.size(); ++i)
    if (resumable(cell_state(s, i, states))) to_resume.push_back(i);
  if (to_resume.empty()) {
    std::printf("sweep: nothing to resume: every cell completed, is queued or is running\n");
    return 0;
  }
  // A completed cell is completed whatever Slurm says; any other may be queued or running there.
  if (!queue_known)
    throw Error(std::to_string(to_resume.size()) + " of the " + std::to_string(s.cells.size()) + " cells of '" +
                o.dir.string() +
                "' did not complete, and squeue failed (above), so whether they are queued or "
                "running is unknown; " +
                slurm_conf_hint() + ". Resuming now could run them twice");
  for (size_t i : to_resume) spdlog::info("sweep: resuming {} ({})", s.cells[i].id, cell_state(s, i, states));
  if (slurm_sweep) {
    write_sweep(s);
    slurm_submit(s, to_resume, o.slurm.sbatch);
    return 0;
  }
  return run_and_summarize(s, to_resume, o.jobs, o.threads);
}

void add_slurm_flags(CLI::App* cmd, SweepOptions& o) {
  cmd->add_option("--cpus-per-task", o.slurm.cpus, "Slurm: CPUs per cell (default: resources.cpus_per_task)")
      ->check(CLI::PositiveNumber);
  cmd->add_option("--time", o.slurm.time, "Slurm: time limit per cell (sbatch --time)");
  cmd->add_option("--mem", o.slurm.memory, "Slurm: memory per cell (sbatch --mem)");
  cmd->add_option("--partition", o.slurm.partition, "Slurm: partition");
  cmd->add_option("--account", o.slurm.account, "Slurm: account");
  cmd->add_option("--sbatch", o.slurm.sbatch, "Slurm: the sbatch command (default: sbatch)");
  cmd->add_option("--jobs", o.jobs, "Local: cells run at once (threads are split between them)")
      ->check(CLI::PositiveNumber);
  cmd->add_option("--threads", o.threads, "Local: threads per cell (default: all cores / --jobs)")
      ->check(CLI::NonNegativeNumber);
}

}  // namespace

void register_sweep(CLI::App& app) {
  auto o = std::make_shared<SweepOptions>();
  auto log_level = std::make_shared<std::string>("info");
  auto* cmd = app.add_subcommand("sweep",
                                 "Run a grid of scenes x contact solvers x parameters here or on a Slurm cluster "
                                 "(subcommands: status, resume, collect, run-cell)");
  cmd->add_option("spec", o->spec, "Sweep specification (YAML, docs/cluster.md)");
  cmd->add_option("--out", o->out, "Sweep directory (one run directory per cell)");
  cmd->add_option("--backend", o->backend, "local (default) or slurm")->check(CLI::IsMember({"local", "slurm"}));
  add_slurm_flags(cmd, *o);
  // --log-level is the global option (main.cpp): checked there, and accepted after the subcommand.

  auto* st = cmd->add_subcommand("status", "State of every cell (squeue/sacct and the cells' run.json)");
  st->add_option("dir", o->dir, "Sweep directory")->required();
  st->callback([o] { guarded([o] { return sweep_status(o->dir); }); });

  auto* rs =
      cmd->add_subcommand("resume", "Run again every failed, cancelled, timed-out or lost cell from its checkpoint");
  rs->add_option("dir", o->dir, "Sweep directory")->required();
  rs->add_option("--backend", o->backend, "local or slurm (default: as the sweep was started)")
      ->check(CLI::IsMember({"local", "slurm"}));
  add_slurm_flags(rs, *o);
  rs->callback([o, rs] {
    init_logging("info");  // its progress, like the sweep's
    if (rs->count("--backend") == 0) o->backend.clear();
    guarded([o] { return resume(*o); });
  });

  auto* co = cmd->add_subcommand("collect", "One table (sweep.csv, sweep.md) over every cell, and a plot");
  co->add_option("dir", o->dir, "Sweep directory")->required();
  co->add_option("--metric", o->metric, "Column of sweep.csv to plot")->capture_default_str();
  co->add_option("--against", o->against, "Swept parameter on the x axis (default: the first)");
  // A plain flag: CLI11 prints a negated one ("!--no-plot") as `--no-plot{false}` in --help.
  auto no_plot = std::make_shared<bool>(false);
  co->add_flag("--no-plot", *no_plot, "Do not draw sweep_<metric>.png");
  co->callback([o, no_plot] {
    init_logging("warn");
    o->plot = !*no_plot;
    guarded([o] { return collect(o->dir, o->metric, o->against, o->plot); });
  });

  // Listed (docs/cli.md, `ccfr sweep --help`): docs/cluster.md's array script calls it by name.
  auto* rc = cmd->add_subcommand(
      "run-cell",
      "Run one cell of a started sweep (what each Slurm array task and each local job runs; docs/cluster.md)");
  rc->add_option("dir", o->dir, "Sweep directory")->required();
  rc->add_option("index", o->index, "Cell index")->required();
  rc->add_option("--threads", o->threads, "Worker threads")->check(CLI::NonNegativeNumber);
  rc->callback([o] {
    init_logging("info");
    guarded([o] { return run_cell(o->dir, o->index, o->threads); });
  });

  cmd->callback([o, log_level, cmd] {
    if (!cmd->get_subcommands().empty()) return;
    init_logging(*log_level);
    guarded([o, cmd] {
      if (cmd->count("--out") > 0 && o->out.empty()) throw Error("--out is empty: give the sweep directory");
      if (o->spec.empty() || o->out.empty())
        throw Error("usage: ccfr sweep SPEC.yaml --out DIR (or status/resume/collect DIR)");
      return start_sweep(*o);
    });
  });
}

}  // namespace ccfr::app
