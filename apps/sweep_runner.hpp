#pragma once
// Sweeps (`ccfr sweep`, `ccfr ablate`): cells of scene × solver × parameter values, each one run
// directory DIR/<cell id>, run here (local backend) or as a Slurm job array, then collected into
// one table. docs/cluster.md. What the cells are (the SPEC.yaml parser and the expansion) is
// ccfr/io/sweep_spec.hpp; how they run is here, implemented in cmd_sweep.cpp.
#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

#include "ccfr/io/sweep_spec.hpp"

namespace ccfr::app {

struct SweepLayout {
  std::filesystem::path dir;
  std::vector<io::SweepCell> cells;
  std::vector<std::string> parameter_keys;
  int audit_stride = 1;
  io::SweepResources resources;
  std::filesystem::path spec;      ///< empty for ablate
  double cell_time_limit_s = 0.0;  ///< spec cell_time_limit; 0: none
};

/// Writes DIR/sweep.json (the cells and how to run them) and creates DIR/logs.
void write_sweep(const SweepLayout& s);
/// Reads DIR/sweep.json back; throws ccfr::Error if DIR is not a sweep.
SweepLayout read_sweep(const std::filesystem::path& dir);
/// Runs `indices` here, `jobs` at once with `threads` each, as `ccfr sweep run-cell` processes
/// logging to DIR/logs/<id>.log. One progress (progress.hpp) on stderr over all of them: frames
/// done of the frames to run, elapsed time, ETA, and the running cells' frames; `label` ("sweep",
/// "ablate") starts its lines. Returns the number of cells that failed.
/// SIGINT or SIGTERM while it runs is passed on to every running cell, which finishes its frame,
/// writes its checkpoint and status and exits; no further cell starts, every running one is waited
/// for, and `*stopped_by` (if given) receives the signal (0 when none came).
int run_local(const SweepLayout& s, const std::vector<size_t>& indices, int jobs, int threads,
              const std::string& label = "sweep", int* stopped_by = nullptr);
/// The exit code of a sweep or ablation stopped by `sig` (docs/cluster.md): 128 + sig, as a shell
/// reports a process killed by it (130 for SIGINT, 143 for SIGTERM).
inline int interrupted_exit_code(int sig) { return 128 + sig; }
/// "SIGINT", "SIGTERM" (or "signal N").
std::string signal_name(int sig);
/// Frames each cell of `indices` runs: its time.frames override, else its scene's time.frames.
std::vector<long> cell_frame_totals(const SweepLayout& s, const std::vector<size_t>& indices);
/// Frames recorded in RUN_DIR/stats.csv (0 when there is none).
long frames_in_stats(const std::filesystem::path& run_dir);

/// One row of the collected table.
struct CellRow {
  std::string id, scene, solver, status, audit;
  std::vector<std::string> values;  ///< one per parameter key
  size_t frames = 0;
  double avg_s = NAN, max_s = NAN, median_s = NAN, xpbd = NAN, broad = NAN, narrow = NAN, resolution = NAN;
  long detected = 0, remaining_sum = 0, remaining_max = 0, halted = 0, contact_vertices = 0;
  long audit_violations = 0;
  double min_over_xi = NAN;
  /// Lag behind the unconstrained (material) step, stats.csv lag_mean averaged over the frames and
  /// lag_max's largest (m); NaN for runs written before those columns.
  double lag_mean = NAN, lag_max = NAN;
  /// Means per frame of stats.csv cpu_s (the work: CPU seconds of all threads) and
  /// outer_iterations (each runs one detection pass, except under `none`); NaN when absent.
  double cpu_s = NAN, outer_iterations = NAN;
  std::vector<std::vector<long>> per_frame;  ///< frame, detected, remaining, halted, contact vertices, audit (-1)
};
/// Reads every cell's run.json, stats.csv and audit.json (auditing a run that has none).
std::vector<CellRow> collect_rows(const SweepLayout& s);
/// The metric columns shared by sweep.csv and ablation.csv, header and row.
std::string metrics_header();
std::string metrics_csv(const CellRow& r);
std::string fmt_num(double v, const char* f = "%.6f");

}  // namespace ccfr::app
