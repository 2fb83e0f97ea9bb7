// `ccfr ablate CONFIG --solvers a,b,c --out DIR`: the same scene once per contact solver, each run
// audited, compared in DIR/ablation.csv, DIR/ablation.md and DIR/ablation.png. The solvers-only
// case of `ccfr sweep` (sweep_layout.hpp): the cells are DIR/<solver>, DIR/sweep.json describes them.
#include <spdlog/spdlog.h>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>

#include "ccfr/core/error.hpp"
#include "ccfr/core/log.hpp"
#include "ccfr/io/dir_lock.hpp"
#include "ccfr/io/obj.hpp"
#include "ccfr/io/run_audit.hpp"
#include "ccfr/solvers/contact_solver.hpp"
#include "commands.hpp"
#include "frame_summary.hpp"
#include "plot_script.hpp"
#include "progress.hpp"
#include "run_driver.hpp"
#include "sweep_collect.hpp"
#include "sweep_layout.hpp"
#include "sweep_local.hpp"

namespace ccfr::app {

namespace {
namespace fs = std::filesystem;

struct AblateOptions {
  RunOptions run;
  std::string solvers;  ///< empty: every registered contact solver
  int audit_stride = 1;
  bool plot = true;
};

std::vector<std::string> split(const std::string& s) {
  std::vector<std::string> out;
  std::stringstream ss(s);
  for (std::string t; std::getline(ss, t, ',');)
    if (!t.empty()) out.push_back(t);
  return out;
}

// True if DIR/sweep.json is an ablation's (ccfr's marker, cells, no spec file).
bool is_ablation_dir(const fs::path& dir) {
  std::ifstream in(dir / "sweep.json");
  if (!in) return false;
  const auto j = nlohmann::json::parse(in, nullptr, /*allow_exceptions=*/false);
  return j.is_object() && j.contains("ccfr") && j["ccfr"].is_object() && j.contains("cells") && j["cells"].is_array() &&
         j.contains("spec") && j["spec"].is_null();
}

// The solvers-only case of a sweep: one cell per solver, in DIR/<solver>, run one after another
// here with the given threads, collected into ablation.csv / ablation.md / ablation_frames.csv.
int run_ablation(AblateOptions& o) {
  if (!o.run.solver.empty())
    throw Error("ccfr ablate compares the solvers of --solvers; --solver '" + o.run.solver +
                "' would be ignored (use --solvers " + o.run.solver + ")");
  const auto names = o.solvers.empty() ? registered_contact_solvers() : split(o.solvers);
  if (names.empty()) throw Error("--solvers is empty");
  for (const auto& n : names) contact_solvers().at(n);  // throws, listing the registered names
  if (!fs::is_regular_file(o.run.config)) throw Error("scene file '" + o.run.config.string() + "' does not exist");
  // Every solver runs to the end so the table compares like with like; a guarantee broken
  // under ccfr shows as remaining violations and an audit failure instead of a stop.
  bool policy_set = false;
  for (const auto& s : o.run.overrides) policy_set = policy_set || s.rfind("contact.on_violation=", 0) == 0;
  if (!policy_set) o.run.overrides.push_back("contact.on_violation=warn");
  if (o.run.out.empty()) throw Error("--out is empty: give the ablation's output directory");
  // One ablation per directory at a time; and only into an empty folder or an earlier ablation, so
  // that no ablation.csv, sweep.json or logs/ of someone else's is overwritten.
  const io::DirLock lock = io::DirLock::acquire(o.run.out, invocation_string());
  if (!io::dir_is_empty(o.run.out) && !is_ablation_dir(o.run.out))
    throw Error("output directory '" + o.run.out.string() +
                "' is not empty and is not a ccfr ablation (no sweep.json written by ccfr ablate); its files "
                "(ablation.csv, ablation.md, sweep.json, logs/, one folder per solver) would be overwritten: choose "
                "another --out");
  SweepLayout s;
  s.dir = o.run.out;
  s.audit_stride = o.audit_stride;
  s.cells = io::expand_sweep({fs::absolute(o.run.config).lexically_normal()}, names, {}, {}, o.run.overrides,
                             o.run.frames, /*solver_ids_only=*/true);
  fs::create_directories(s.dir);
  write_sweep(s);
  std::vector<size_t> all(s.cells.size());
  for (size_t i = 0; i < all.size(); ++i) all[i] = i;
  const auto t0 = std::chrono::steady_clock::now();
  int stopped_by = 0;
  const int failed = run_local(s, all, 1, o.run.threads, "ablate", &stopped_by);
  const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (stopped_by) {
    // No tables from cells cut short: the same command again continues them from their checkpoints.
    std::printf(
        "ablate: stopped by %s after %s: the running solver wrote its checkpoint, no table was written; "
        "the same command again continues\n",
        signal_name(stopped_by).c_str(), format_duration(secs).c_str());
    return interrupted_exit_code(stopped_by);
  }
  const auto rows = collect_rows(s);

  std::string frames_csv =
      "solver,frame,violations_detected,violations_remaining,halted_vertices,contact_vertices,audit_penetrations\n";
  std::string csv = "solver," + metrics_header() + "\n";
  std::string md = "# Ablation of `" + o.run.config.string() + "`\n\nEach solver ran the same scene";
  md += o.run.frames >= 0 ? " for " + std::to_string(o.run.frames) + " frames" : std::string();
  md += "; every run was audited with `ccfr audit` (stride " + std::to_string(o.audit_stride) + ").\n\n";
  md +=
      "| solver | frames | mean s/frame | max s/frame | XPBD | broad | narrow | resolution | violations detected | "
      "remaining (sum / max) | halted | audit | min dist / ξ |\n";
  md += "|---|---|---|---|---|---|---|---|---|---|---|---|---|\n";
  for (const auto& r : rows) {
    csv += r.solver + "," + metrics_csv(r) + "\n";
    md += "| `" + r.solver + "` | " + std::to_string(r.frames) + " | " + fmt_num(r.avg_s, "%.4f") + " | " +
          fmt_num(r.max_s, "%.4f") + " | " + fmt_num(r.xpbd, "%.4f") + " | " + fmt_num(r.broad, "%.4f") + " | " +
          fmt_num(r.narrow, "%.4f") + " | " + fmt_num(r.resolution, "%.4f") + " | " + std::to_string(r.detected) +
          " | " + std::to_string(r.remaining_sum) + " / " + std::to_string(r.remaining_max) + " | " +
          std::to_string(r.halted) + " | " + r.audit +
          (r.audit == "fail" ? " (" + std::to_string(r.audit_violations) + ")" : std::string()) + " | " +
          fmt_num(r.min_over_xi, "%.6f") + " |\n";
    for (const auto& f : r.per_frame)
      frames_csv += r.solver + "," + std::to_string(f[0]) + "," + std::to_string(f[1]) + "," + std::to_string(f[2]) +
                    "," + std::to_string(f[3]) + "," + std::to_string(f[4]) + "," +
                    (f[5] >= 0 ? std::to_string(f[5]) : "") + "\n";
  }
  md += "\nTimes are seconds per frame (means over frames); the stage columns are the paper's breakdown.\n";
  const fs::path root = s.dir;
  io::write_file_atomic(root / "ablation.csv", csv);
  io::write_file_atomic(root / "ablation.md", md);
  io::write_file_atomic(root / "ablation_frames.csv", frames_csv);
  std::fputs(md.c_str(), stdout);
  if (o.plot) {
    std::string why;
    if (!run_plot_script("plot_ablation.py", {root.string()}, why))
      spdlog::warn("ablate: no ablation.png ({}); the tables are written", why);
  }
  bool all_ran = true;
  size_t frames = 0, passed = 0;
  for (const auto& r : rows) {
    all_ran = all_ran && r.audit != "error";
    frames += r.frames;
    passed += r.audit == "pass";
  }
  std::printf(
      "\nablate: %zu solvers, %zu frames in %s (%s/frame), %d failed to run, %zu of %zu passed the audit; "
      "tables in %s; next: ccfr plot %s\n",
      rows.size(), frames, format_duration(secs).c_str(),
      format_duration(frames ? secs / static_cast<double>(frames) : NAN).c_str(), failed, passed, rows.size(),
      (root / "ablation.md").string().c_str(), shell_quote(root.string()).c_str());
  // A solver whose run failed (a bad override, a folder in the way, a stop) fails the ablation.
  return all_ran && failed == 0 ? 0 : 1;
}
}  // namespace

void register_ablate(CLI::App& app) {
  auto o = std::make_shared<AblateOptions>();
  auto log_level = std::make_shared<std::string>("info");
  auto* cmd = app.add_subcommand("ablate",
                                 "Run one scene under several contact solvers, audit each run, compare them "
                                 "(ablation.csv, .md, .png; the solvers-only case of ccfr sweep)");
  cmd->add_option("config", o->run.config, "Scene file (YAML)")->required();
  std::string all;
  for (const auto& n : registered_contact_solvers()) all += (all.empty() ? "" : ",") + n;
  cmd->add_option("--solvers", o->solvers,
                  "Comma-separated contact solvers (default: every registered one: " + all + ")");
  cmd->add_option("--out", o->run.out, "Output directory (one sub-directory per solver)")->required();
  cmd->add_option("--audit-stride", o->audit_stride, "Audit every K-th frame")->check(CLI::PositiveNumber);
  // A plain flag: CLI11 prints a negated one ("!--no-plot") as `--no-plot{false}` in --help.
  auto no_plot = std::make_shared<bool>(false);
  cmd->add_flag("--no-plot", *no_plot, "Do not draw ablation.png");
  // --log-level is the global option (main.cpp): checked there, and accepted after the subcommand.
  add_run_options(cmd, o->run);
  // --solver (from the run options) names one solver where ablate compares --solvers: hidden from
  // --help and the docs, still parsed so that run_ablation refuses it with a hint.
  cmd->get_option("--solver")->group("");
  cmd->callback([o, log_level, no_plot] {
    init_logging(*log_level);
    o->plot = !*no_plot;
    o->run.progress = false;
    guarded([o] { return run_ablation(*o); });
  });
}

}  // namespace ccfr::app
