#pragma once
// One cell of a sweep: `ccfr sweep run-cell DIR INDEX` (what each local job and each Slurm array
// task runs), and the frames a cell runs and has run.
#include <filesystem>
#include <vector>

#include "sweep_layout.hpp"

namespace ccfr::app {

/// Runs cell `index` of the sweep in `dir` with `threads` worker threads: continues it from its
/// checkpoint when it has one and has not completed, runs it from the start otherwise, audits its
/// frames into audit.json and records the outcome in DIR/logs/<id>.json. Returns the run's exit
/// code; throws ccfr::Error when the run is refused.
int run_cell(const std::filesystem::path& dir, long index, int threads);
/// Frames each cell of `indices` runs: its time.frames override, else its scene's time.frames.
std::vector<long> cell_frame_totals(const SweepLayout& s, const std::vector<size_t>& indices);
/// Frames recorded in RUN_DIR/stats.csv (0 when there is none).
long frames_in_stats(const std::filesystem::path& run_dir);

}  // namespace ccfr::app
