// `ccfr sweep run-cell DIR INDEX` (sweep_cell.hpp): one cell run, resumed or reused, audited and
// recorded in DIR/logs/<id>.json; and the frame counts the progress of a sweep is made of.
#include "sweep_cell.hpp"

#include <unistd.h>

#include <spdlog/spdlog.h>
#include <algorithm>
#include <cstdlib>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>

#include "ccfr/core/error.hpp"
#include "ccfr/io/checkpoint.hpp"
#include "ccfr/io/dir_lock.hpp"
#include "ccfr/io/obj.hpp"
#include "ccfr/io/output.hpp"
#include "ccfr/io/run_audit.hpp"
#include "ccfr/io/run_json.hpp"
#include "ccfr/io/scene_loader.hpp"
#include "run_driver.hpp"

namespace ccfr::app {

namespace fs = std::filesystem;
using Json = nlohmann::ordered_json;

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

// What the cell's earlier run in `out` is worth now: `completed` only when it completed this
// cell's configuration; `changed` (empty when not) says why it is of another configuration.
struct EarlierRun {
  bool completed = false;
  std::string changed;
};

// The cell's earlier run counts only if it ran this cell's configuration: an ablation or sweep
// rerun into the same directory with other --frames or --set starts the cell again instead of
// reusing (or resuming) a run of the old one.
EarlierRun earlier_run(const fs::path& out, const io::SweepCell& c) {
  EarlierRun e;
  e.completed = io::is_ccfr_run(out) && io::read_run_info(out).progress.status == "completed";
  if (e.completed) {
    const Json run = read_json(out / "run.json");
    try {
      e.changed =
          io::json_difference(run.value("config", Json()).dump(), io::load_scene(c.config, c.overrides).resolved_json);
    } catch (const Error&) {
      e.changed = "its scene no longer loads";  // the run below reports why
    }
    e.completed = e.changed.empty();
  } else if (const auto ck = io::is_ccfr_run(out) ? io::latest_checkpoint(out) : std::nullopt) {
    try {
      const io::Checkpoint k = io::read_checkpoint(*ck);
      if (k.overrides != c.overrides || k.scene_file != fs::absolute(c.config).lexically_normal())
        e.changed = "its checkpoint was written with other overrides or another scene file";
    } catch (const Error&) {
      // A damaged checkpoint: resuming reports it.
    }
  }
  return e;
}

// The run of the cell into `out`: resumed from its latest checkpoint when the earlier run there is
// of this configuration and unfinished, else from the start.
RunOptions cell_run_options(const SweepLayout& s, const io::SweepCell& c, const fs::path& out, int threads,
                            const EarlierRun& earlier, const std::string& command) {
  RunOptions ro;
  ro.threads = threads;
  ro.time_limit_s = s.cell_time_limit_s;
  ro.progress = true;
  if (io::is_ccfr_run(out) && !earlier.completed && earlier.changed.empty() && io::latest_checkpoint(out)) {
    ro.resume = out;
  } else {
    ro.config = c.config;
    ro.overrides = c.overrides;
    ro.out = out;
  }
  ro.command_line = command;
  return ro;
}

// How this attempt ended: the run's exit code, its status and the signal that stopped it (0: none).
struct Attempt {
  int code = 0;
  std::string status;
  int stop_signal = 0;
};

// Runs the cell unless it completed earlier with this configuration. A run refused before or while
// running is recorded as such in DIR/logs/<id>.json, and its error rethrown.
Attempt run_attempt(const fs::path& dir, const io::SweepCell& c, long index, const RunOptions& ro, bool completed) {
  Attempt a;
  if (completed) {
    a.status = "completed";
    return a;
  }
  try {
    const RunSummary r = run_scene(ro);
    a.code = run_exit_code(r);
    a.status = r.status;
    a.stop_signal = r.stop_signal;
  } catch (const Error& e) {
    // Refused before or while running (a checkpoint of another build, a scene that no longer
    // loads): the record says so, not the status an earlier attempt left in run.json.
    write_cell_record(dir, c, index, 2, std::string("error: ") + e.what(), "not audited (the run did not start)");
    throw;
  }
  return a;
}

// Audits the frames written in `out` into `out`/audit.json and returns the verdict: pass, fail,
// incomplete (clean frames of an unfinished run), or error when the audit itself failed.
std::string audit_cell(const fs::path& out, const std::string& id, int stride) {
  std::string verdict = "error";
  try {
    io::RunAuditOptions ao;
    ao.stride = stride;
    const auto a = io::audit_run(out, ao);
    verdict = !a.clean() ? "fail" : a.completed() ? "pass" : "incomplete";
    const int acode = io::audit_exit_code(a, verdict);
    io::write_file_atomic(out / "audit.json", io::audit_report_json(a, verdict, acode, verdict == "incomplete"));
  } catch (const Error& e) {
    spdlog::error("sweep cell {}: audit failed: {}", id, e.what());
  }
  return verdict;
}

}  // namespace

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
  const EarlierRun earlier = earlier_run(out, c);
  if (!earlier.changed.empty())
    spdlog::info("sweep cell {} ({}): the run in {} is of another configuration ({}): running it again", index, c.id,
                 out.string(), earlier.changed);
  const RunOptions ro = cell_run_options(s, c, out, threads, earlier, command);
  spdlog::info("sweep cell {} ({}): {}", index, c.id,
               earlier.completed   ? "completed earlier with this configuration; auditing its frames again"
               : ro.resume.empty() ? "from the start"
                                   : "resuming");
  const Attempt a = run_attempt(dir, c, index, ro, earlier.completed);
  // A cell stopped by a signal is not audited now: whoever stopped it wants it to end; `sweep
  // collect` audits it later.
  const std::string verdict = a.stop_signal ? "not audited (stopped)" : audit_cell(out, c.id, s.audit_stride);
  write_cell_record(dir, c, index, a.code, a.status, verdict);
  return a.code;
}

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

}  // namespace ccfr::app
