// `ccfr ablate CONFIG --solvers a,b,c --out DIR`: the same scene once per contact solver, each run
// audited, compared in DIR/ablation.csv, DIR/ablation.md and DIR/ablation.png.
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

#include "ccfr/core/error.hpp"
#include "ccfr/core/log.hpp"
#include "ccfr/io/obj.hpp"
#include "ccfr/io/run_audit.hpp"
#include "ccfr/solvers/contact_solver.hpp"
#include "commands.hpp"
#include "frame_summary.hpp"
#include "run_driver.hpp"

namespace ccfr::app {

namespace {
namespace fs = std::filesystem;

struct AblateOptions {
  RunOptions run;
  std::string solvers;  ///< empty: every registered contact solver
  int audit_stride = 1;
  bool plot = true;
};

struct Row {
  std::string solver, status, audit;
  Aggregate frame, xpbd, broad, narrow, resolution;
  long detected = 0, remaining_sum = 0, remaining_max = 0, halted = 0;
  double min_over_xi = NAN;
  Index audit_violations = 0;
  size_t frames = 0;
};

std::vector<std::string> split(const std::string& s) {
  std::vector<std::string> out;
  std::stringstream ss(s);
  for (std::string t; std::getline(ss, t, ',');)
    if (!t.empty()) out.push_back(t);
  return out;
}

std::string fmt(double v, const char* f = "%.6f") {
  if (!std::isfinite(v)) return "";
  char b[64];
  std::snprintf(b, sizeof b, f, v);
  return b;
}

int run_ablation(AblateOptions& o) {
  const auto names = o.solvers.empty() ? registered_contact_solvers() : split(o.solvers);
  if (names.empty()) throw Error("--solvers is empty");
  for (const auto& n : names) contact_solvers().at(n);  // throws, listing the registered names
  const fs::path root = o.run.out;
  fs::create_directories(root);
  std::vector<Row> rows;
  // Per frame and solver: what the solver reports and what the audit finds, so a baseline that
  // leaves residual violations shows them frame by frame (ablation_frames.csv, plotted).
  std::string frames_csv = "solver,frame,violations_detected,violations_remaining,halted_vertices,contact_vertices,audit_penetrations\n";
  // Every solver runs to the end so the table compares like with like; a guarantee broken
  // under ccfr shows as remaining violations and an audit failure instead of a stop.
  bool policy_set = false;
  for (const auto& s : o.run.overrides) policy_set = policy_set || s.rfind("contact.on_violation=", 0) == 0;
  if (!policy_set) o.run.overrides.push_back("contact.on_violation=warn");
  for (const auto& name : names) {
    RunOptions ro = o.run;
    ro.solver = name;
    ro.out = root / name;
    ro.command_line = "ccfr ablate " + o.run.config.string() + " (solver " + name + ")";
    spdlog::info("ablate: {} -> {}", name, ro.out.string());
    const RunSummary s = run_scene(ro);
    Row r;
    r.solver = name;
    r.status = s.status;
    r.frames = s.frames.size();
    r.frame = aggregate(s.frames, [](const FrameStats& f) { return f.wall_s; });
    r.xpbd = aggregate(s.frames, [](const FrameStats& f) { return f.times.xpbd; });
    r.broad = aggregate(s.frames, [](const FrameStats& f) { return f.times.broad; });
    r.narrow = aggregate(s.frames, [](const FrameStats& f) { return f.times.narrow; });
    r.resolution = aggregate(s.frames, [](const FrameStats& f) { return f.times.resolution; });
    for (const auto& f : s.frames) {
      r.detected += f.violations_detected;
      r.remaining_sum += f.violations_remaining;
      r.remaining_max = std::max<long>(r.remaining_max, f.violations_remaining);
      r.halted += f.halted_vertices;
    }
    std::map<long, Index> audit_by_frame;
    try {
      io::RunAuditOptions ao;
      ao.stride = o.audit_stride;
      const auto a = io::audit_run(ro.out, ao, [&](long frame, const exact::FrameAudit& fa) { audit_by_frame[frame] = fa.penetrations(); });
      r.audit = a.clean() ? "pass" : "fail";
      r.audit_violations = a.violations;
      r.min_over_xi = std::isfinite(a.min_distance) ? a.min_distance / a.offset : NAN;
    } catch (const Error& e) {
      r.audit = "error";
      spdlog::error("ablate: audit of {} failed: {}", ro.out.string(), e.what());
    }
    for (const auto& f : s.frames) {
      const auto it = audit_by_frame.find(f.frame);
      frames_csv += name + "," + std::to_string(f.frame) + "," + std::to_string(f.violations_detected) + "," +
                    std::to_string(f.violations_remaining) + "," + std::to_string(f.halted_vertices) + "," +
                    std::to_string(f.contact_vertices) + "," + (it != audit_by_frame.end() ? std::to_string(it->second) : "") + "\n";
    }
    spdlog::info("ablate: {}: {} frames, mean {:.4f} s/frame, audit {} ({} violations)", name, r.frames, r.frame.mean, r.audit,
                 r.audit_violations);
    rows.push_back(r);
  }

  std::string csv =
      "solver,frames,status,avg_frame_s,max_frame_s,median_frame_s,xpbd_s,broad_s,narrow_s,resolution_s,violations_detected,"
      "violations_remaining,max_violations_remaining,halted_vertices,audit,audit_violations,min_distance_over_offset\n";
  std::string md = "# Ablation of `" + o.run.config.string() + "`\n\nEach solver ran the same scene";
  md += o.run.frames >= 0 ? " for " + std::to_string(o.run.frames) + " frames" : std::string();
  md += "; every run was audited with `ccfr audit` (stride " + std::to_string(o.audit_stride) + ").\n\n";
  md += "| solver | frames | mean s/frame | max s/frame | XPBD | broad | narrow | resolution | violations detected | remaining (sum / max) | halted | audit | min dist / ξ |\n";
  md += "|---|---|---|---|---|---|---|---|---|---|---|---|---|\n";
  for (const auto& r : rows) {
    std::string status = r.status;
    std::replace(status.begin(), status.end(), ',', ';');
    csv += r.solver + "," + std::to_string(r.frames) + "," + status + "," + fmt(r.frame.mean) + "," + fmt(r.frame.max) + "," +
           fmt(r.frame.median) + "," + fmt(r.xpbd.mean) + "," + fmt(r.broad.mean) + "," + fmt(r.narrow.mean) + "," +
           fmt(r.resolution.mean) + "," + std::to_string(r.detected) + "," + std::to_string(r.remaining_sum) + "," +
           std::to_string(r.remaining_max) + "," + std::to_string(r.halted) + "," + r.audit + "," +
           std::to_string(r.audit_violations) + "," + fmt(r.min_over_xi, "%.9f") + "\n";
    md += "| `" + r.solver + "` | " + std::to_string(r.frames) + " | " + fmt(r.frame.mean, "%.4f") + " | " + fmt(r.frame.max, "%.4f") +
          " | " + fmt(r.xpbd.mean, "%.4f") + " | " + fmt(r.broad.mean, "%.4f") + " | " + fmt(r.narrow.mean, "%.4f") + " | " +
          fmt(r.resolution.mean, "%.4f") + " | " + std::to_string(r.detected) + " | " + std::to_string(r.remaining_sum) + " / " +
          std::to_string(r.remaining_max) + " | " + std::to_string(r.halted) + " | " + r.audit +
          (r.audit == "fail" ? " (" + std::to_string(r.audit_violations) + ")" : std::string()) + " | " +
          fmt(r.min_over_xi, "%.6f") + " |\n";
  }
  md += "\nTimes are seconds per frame (means over frames); the stage columns are the paper's breakdown.\n";
  io::write_file_atomic(root / "ablation.csv", csv);
  io::write_file_atomic(root / "ablation.md", md);
  io::write_file_atomic(root / "ablation_frames.csv", frames_csv);
  std::fputs(md.c_str(), stdout);
  if (o.plot) {
    const fs::path script = fs::path(CCFR_SOURCE_DIR) / "scripts" / "plot_ablation.py";
    if (fs::exists(script) && fs::exists("/usr/bin/python3")) {
      const std::string cmd = "/usr/bin/python3 '" + script.string() + "' '" + root.string() + "' > /dev/null 2>&1";
      if (std::system(cmd.c_str()) != 0) spdlog::warn("ablate: plotting failed ({}); the tables are written", cmd);
    }
  }
  bool all_ran = true;
  for (const auto& r : rows) all_ran = all_ran && r.audit != "error";
  return all_ran ? 0 : 1;
}
}  // namespace

void register_ablate(CLI::App& app) {
  auto o = std::make_shared<AblateOptions>();
  auto log_level = std::make_shared<std::string>("info");
  auto* cmd = app.add_subcommand("ablate", "Run one scene under several contact solvers, audit each run, compare them");
  cmd->add_option("config", o->run.config, "Scene file (YAML)")->required();
  std::string all;
  for (const auto& n : registered_contact_solvers()) all += (all.empty() ? "" : ",") + n;
  cmd->add_option("--solvers", o->solvers, "Comma-separated contact solvers (default: every registered one: " + all + ")");
  cmd->add_option("--out", o->run.out, "Output directory (one sub-directory per solver)")->required();
  cmd->add_option("--audit-stride", o->audit_stride, "Audit every K-th frame")->check(CLI::PositiveNumber);
  cmd->add_flag("!--no-plot", o->plot, "Do not draw ablation.png");
  cmd->add_option("--log-level", *log_level, "trace, debug, info, warn, error or off");
  add_run_options(cmd, o->run);
  cmd->callback([o, log_level] {
    init_logging(*log_level);
    o->run.progress = false;
    guarded([o] { return run_ablation(*o); });
  });
}

}  // namespace ccfr::app
