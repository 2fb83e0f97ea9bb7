#pragma once
// Collecting a sweep's cells into one table: each cell's run.json, stats.csv and audit.json become
// a CellRow (`ccfr sweep collect`, `ccfr ablate`), written as sweep.csv and sweep.md.
#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

#include "sweep_layout.hpp"

namespace ccfr::app {

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
/// `v` printed with `f`; "" when it is not finite.
std::string fmt_num(double v, const char* f = "%.6f");
/// `ccfr sweep collect DIR`: writes DIR/sweep.csv and DIR/sweep.md (printed too) and, with `plot`,
/// DIR/sweep_<metric>.png against the swept key `against` (default: the first); returns 1 when a
/// cell did not pass the audit or did not complete, else 0.
int collect_sweep(const std::filesystem::path& dir, const std::string& metric, const std::string& against, bool plot);

}  // namespace ccfr::app
