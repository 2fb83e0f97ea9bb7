// `ccfr sweep status` (sweep_status.hpp): each cell's state from Slurm, its lock and its run.json,
// with its frames and latest checkpoint, and the command to run next.
#include "sweep_status.hpp"

#include <algorithm>
#include <cstdio>
#include <optional>
#include <vector>

#include "ccfr/io/checkpoint.hpp"
#include "ccfr/io/dir_lock.hpp"
#include "ccfr/io/output.hpp"
#include "ccfr/io/run_json.hpp"
#include "run_driver.hpp"
#include "sweep_cell.hpp"
#include "sweep_slurm.hpp"

namespace ccfr::app {

namespace fs = std::filesystem;

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

}  // namespace ccfr::app
