// `ccfr sweep SPEC --out DIR` and `ccfr sweep resume DIR` (sweep_start.hpp): the sweep directory
// checked and written, the cells to run chosen, and the local or Slurm backend run on them.
#include "sweep_start.hpp"

#include <spdlog/spdlog.h>
#include <chrono>
#include <cstdio>
#include <nlohmann/json.hpp>
#include <vector>

#include "ccfr/core/error.hpp"
#include "ccfr/io/dir_lock.hpp"
#include "ccfr/io/sweep_spec.hpp"
#include "progress.hpp"
#include "run_driver.hpp"
#include "sweep_cell.hpp"
#include "sweep_local.hpp"
#include "sweep_status.hpp"

namespace ccfr::app {

namespace fs = std::filesystem;
using Json = nlohmann::ordered_json;

namespace {

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

}  // namespace

int start_sweep(const fs::path& spec_file, const fs::path& out, const SweepBackend& b) {
  io::SweepSpec spec = io::load_sweep_spec(spec_file);
  SweepLayout s{
      out, spec.cells, spec.parameter_keys, spec.audit_stride, spec.resources, spec.file, spec.cell_time_limit_s};
  apply_flags(s.resources, b.slurm);
  // One sweep process per sweep directory (its cells are locked apart by their run-cell).
  const io::DirLock lock = io::DirLock::acquire(out, invocation_string());
  if (fs::exists(out / "sweep.json")) {
    const SweepLayout old = read_sweep(out);
    std::vector<std::string> old_ids, new_ids;
    for (const auto& c : old.cells) old_ids.push_back(c.id);
    for (const auto& c : s.cells) new_ids.push_back(c.id);
    if (old_ids != new_ids)
      throw Error("'" + out.string() +
                  "' holds another sweep (its cells differ); choose another --out, or use `ccfr "
                  "sweep resume`");
  } else if (!io::dir_is_empty(out)) {
    throw Error("output directory '" + out.string() + "' is not empty and is not a sweep; choose another --out");
  }
  std::vector<size_t> all(s.cells.size());
  for (size_t i = 0; i < all.size(); ++i) all[i] = i;
  if (b.backend == "slurm") check_slurm_array_size(s, all);  // before the sweep's folder is written
  write_sweep(s);
  spdlog::info("sweep: {} cells in {}", all.size(), out.string());
  if (b.backend == "slurm") {
    slurm_submit(s, all, b.slurm.sbatch);
    return 0;
  }
  return run_and_summarize(s, all, b.jobs, b.threads);
}

int resume_sweep(const fs::path& dir, const SweepBackend& b) {
  SweepLayout s = read_sweep(dir);
  const io::DirLock lock = io::DirLock::acquire(dir, invocation_string());
  apply_flags(s.resources, b.slurm);
  const Json j = read_json(dir / "sweep.json");
  const bool slurm_sweep =
      b.backend == "slurm" || (b.backend.empty() && j.contains("slurm_jobs") && !j.at("slurm_jobs").empty());
  bool queue_known = true;
  const auto states = slurm_states(dir, &queue_known);
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
                dir.string() +
                "' did not complete, and squeue failed (above), so whether they are queued or "
                "running is unknown; " +
                slurm_conf_hint() + ". Resuming now could run them twice");
  for (size_t i : to_resume) spdlog::info("sweep: resuming {} ({})", s.cells[i].id, cell_state(s, i, states));
  if (slurm_sweep) {
    write_sweep(s);
    slurm_submit(s, to_resume, b.slurm.sbatch);
    return 0;
  }
  return run_and_summarize(s, to_resume, b.jobs, b.threads);
}

}  // namespace ccfr::app
