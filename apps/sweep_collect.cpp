// `ccfr sweep collect` (sweep_collect.hpp): one CellRow per cell from its run directory (auditing
// it when its audit.json is stale), written as sweep.csv and sweep.md and plotted.
#include "sweep_collect.hpp"

#include <spdlog/spdlog.h>
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <nlohmann/json.hpp>

#include "ccfr/core/error.hpp"
#include "ccfr/io/obj.hpp"
#include "ccfr/io/output.hpp"
#include "ccfr/io/run_audit.hpp"
#include "ccfr/io/stats_csv.hpp"
#include "frame_summary.hpp"
#include "progress.hpp"
#include "run_driver.hpp"
#include "sweep_shell.hpp"

namespace ccfr::app {

namespace fs = std::filesystem;
using Json = nlohmann::ordered_json;

std::string fmt_num(double v, const char* f) {
  if (!std::isfinite(v)) return "";
  char b[64];
  std::snprintf(b, sizeof b, f, v);
  return b;
}

namespace {

// The frame statistics of stats.csv into `r`: means (and the median and maximum of the wall time)
// over the frames, sums of the violation counts. stats.csv is read by column name (kStatsColumns):
// a run of an older ccfr may lack the newer columns, whose figures then stay NaN.
void add_stats(CellRow& r, const io::StatsCsv& stats) {
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
}

// The audit of the run in `out`: the cell's own audit.json (run-cell writes it) while it is of the
// run's frames and `status`, else one made now with `stride` and written; {"verdict": "error"} when
// that fails.
Json cell_audit(const fs::path& out, const Json& run, const std::string& status, int stride) {
  Json audit = read_json(out / "audit.json");
  const bool stale = !audit.is_object() || audit.value("frames_total", -1L) != run.value("frames_written", -2L) ||
                     audit.value("status", Json()).dump() != Json(status).dump();
  if (stale) {
    try {
      io::RunAuditOptions ao;
      ao.stride = stride;
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
  return audit;
}

// The audit's verdict, violations and min distance / ξ into `r`, and r.per_frame: one row per frame
// of `fsv`, its audit penetrations -1 where the audit did not check that frame.
void add_audit(CellRow& r, Json& audit, const std::vector<FrameStats>& fsv) {
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
}

// Cell c's row: status "not run" when DIR/<id> holds no run.
CellRow collect_row(const SweepLayout& s, const io::SweepCell& c) {
  CellRow r;
  r.id = c.id;
  r.scene = c.scene;
  r.solver = c.solver;
  for (const auto& [k, v] : c.params) r.values.push_back(v);
  const fs::path out = s.dir / c.id;
  if (!io::is_ccfr_run(out)) {
    r.status = "not run";
    r.audit = "";
    return r;
  }
  const Json run = read_json(out / "run.json");
  r.status = run.value("status", std::string());
  if (r.solver.empty()) r.solver = run.value("solver", std::string());
  const io::StatsCsv stats = io::read_stats_csv(out / "stats.csv");
  add_stats(r, stats);
  Json audit = cell_audit(out, run, r.status, s.audit_stride);
  add_audit(r, audit, stats.rows);
  return r;
}

// Halted vertices as a percentage of the contact vertices over the run; NaN without any.
double halting_percent(const CellRow& r) {
  return r.contact_vertices > 0 ? 100.0 * r.halted / r.contact_vertices : NAN;
}

// sweep.csv: a line per cell with its swept values, halting percent and the metric columns.
std::string sweep_csv(const SweepLayout& s, const std::vector<CellRow>& rows) {
  std::string head = "cell,scene,solver";
  for (const auto& k : s.parameter_keys) head += "," + k;
  std::string csv = head + ",halting_percent," + metrics_header() + "\n";
  for (const auto& r : rows) {
    csv += r.id + "," + r.scene + "," + r.solver;
    for (const auto& v : r.values) csv += "," + v;
    csv += "," + fmt_num(halting_percent(r), "%.4f") + "," + metrics_csv(r) + "\n";
  }
  return csv;
}

// sweep.md: the table for reading (mean seconds per frame), under a heading naming the sweep `dir`.
std::string sweep_md(const SweepLayout& s, const fs::path& dir, const std::vector<CellRow>& rows) {
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
    const double halting = halting_percent(r);
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
  return md;
}

// DIR/sweep_<metric>.png by scripts/plot_sweep.py against `against` (default: the first swept key),
// when the script and /usr/bin/python3 are there; a failure is a warning (the tables are written).
void plot_sweep(const SweepLayout& s, const fs::path& dir, const std::string& metric, const std::string& against) {
  const std::string x = against.empty() && !s.parameter_keys.empty() ? s.parameter_keys.front() : against;
  const fs::path script = fs::path(CCFR_SOURCE_DIR) / "scripts" / "plot_sweep.py";
  if (!x.empty() && fs::exists(script) && fs::exists("/usr/bin/python3")) {
    const std::string cmd = "/usr/bin/python3 " + single_quote(script.string()) + " " +
                            single_quote((dir / "sweep.csv").string()) + " --metric " + single_quote(metric) +
                            " --against " + single_quote(x) + " > /dev/null 2>&1";
    if (std::system(cmd.c_str()) != 0) spdlog::warn("sweep collect: plotting failed ({}); the tables are written", cmd);
  }
}

// The closing lines: the cells that did not pass the audit or complete, and the command to run next
// (since `t0`); returns 1 when there are any such cells, else 0.
int collect_summary(const fs::path& dir, const std::vector<CellRow>& rows, std::chrono::steady_clock::time_point t0) {
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

}  // namespace

std::vector<CellRow> collect_rows(const SweepLayout& s) {
  std::vector<CellRow> rows;
  for (const auto& c : s.cells) rows.push_back(collect_row(s, c));
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

int collect_sweep(const fs::path& dir, const std::string& metric, const std::string& against, bool plot) {
  const auto t0 = std::chrono::steady_clock::now();
  const SweepLayout s = read_sweep(dir);
  const auto rows = collect_rows(s);
  const std::string md = sweep_md(s, dir, rows);
  io::write_file_atomic(dir / "sweep.csv", sweep_csv(s, rows));
  io::write_file_atomic(dir / "sweep.md", md);
  std::fputs(md.c_str(), stdout);
  if (plot) plot_sweep(s, dir, metric, against);
  return collect_summary(dir, rows, t0);
}

}  // namespace ccfr::app
