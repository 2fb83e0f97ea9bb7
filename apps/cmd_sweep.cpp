// `ccfr sweep SPEC.yaml --out DIR` and its subcommands status, resume, collect and run-cell: the
// command line of each and the sweep_*.hpp function it runs (grids of runs, docs/cluster.md).
#include <filesystem>
#include <memory>
#include <string>

#include "ccfr/core/error.hpp"
#include "ccfr/core/log.hpp"
#include "commands.hpp"
#include "sweep_cell.hpp"
#include "sweep_collect.hpp"
#include "sweep_start.hpp"
#include "sweep_status.hpp"

namespace ccfr::app {

namespace fs = std::filesystem;

namespace {

struct SweepOptions {
  fs::path spec, out;
  SweepBackend run;
  fs::path dir;  // subcommands
  long index = -1;
  std::string metric = "avg_frame_s", against;
  bool plot = true;
};

void add_slurm_flags(CLI::App* cmd, SweepOptions& o) {
  cmd->add_option("--cpus-per-task", o.run.slurm.cpus, "Slurm: CPUs per cell (default: resources.cpus_per_task)")
      ->check(CLI::PositiveNumber);
  cmd->add_option("--time", o.run.slurm.time, "Slurm: time limit per cell (sbatch --time)");
  cmd->add_option("--mem", o.run.slurm.memory, "Slurm: memory per cell (sbatch --mem)");
  cmd->add_option("--partition", o.run.slurm.partition, "Slurm: partition");
  cmd->add_option("--account", o.run.slurm.account, "Slurm: account");
  cmd->add_option("--sbatch", o.run.slurm.sbatch, "Slurm: the sbatch command (default: sbatch)");
  cmd->add_option("--jobs", o.run.jobs, "Local: cells run at once (threads are split between them)")
      ->check(CLI::PositiveNumber);
  cmd->add_option("--threads", o.run.threads, "Local: threads per cell (default: all cores / --jobs)")
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
  cmd->add_option("--backend", o->run.backend, "local (default) or slurm")->check(CLI::IsMember({"local", "slurm"}));
  add_slurm_flags(cmd, *o);
  // --log-level is the global option (main.cpp): checked there, and accepted after the subcommand.

  auto* st = cmd->add_subcommand("status", "State of every cell (squeue/sacct and the cells' run.json)");
  st->add_option("dir", o->dir, "Sweep directory")->required();
  st->callback([o] { guarded([o] { return sweep_status(o->dir); }); });

  auto* rs =
      cmd->add_subcommand("resume", "Run again every failed, cancelled, timed-out or lost cell from its checkpoint");
  rs->add_option("dir", o->dir, "Sweep directory")->required();
  rs->add_option("--backend", o->run.backend, "local or slurm (default: as the sweep was started)")
      ->check(CLI::IsMember({"local", "slurm"}));
  add_slurm_flags(rs, *o);
  rs->callback([o, rs] {
    init_logging("info");  // its progress, like the sweep's
    if (rs->count("--backend") == 0) o->run.backend.clear();
    guarded([o] { return resume_sweep(o->dir, o->run); });
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
    guarded([o] { return collect_sweep(o->dir, o->metric, o->against, o->plot); });
  });

  // Listed (docs/cli.md, `ccfr sweep --help`): docs/cluster.md's array script calls it by name.
  auto* rc = cmd->add_subcommand(
      "run-cell",
      "Run one cell of a started sweep (what each Slurm array task and each local job runs; docs/cluster.md)");
  rc->add_option("dir", o->dir, "Sweep directory")->required();
  rc->add_option("index", o->index, "Cell index")->required();
  rc->add_option("--threads", o->run.threads, "Worker threads")->check(CLI::NonNegativeNumber);
  rc->callback([o] {
    init_logging("info");
    guarded([o] { return run_cell(o->dir, o->index, o->run.threads); });
  });

  cmd->callback([o, log_level, cmd] {
    if (!cmd->get_subcommands().empty()) return;
    init_logging(*log_level);
    guarded([o, cmd] {
      if (cmd->count("--out") > 0 && o->out.empty()) throw Error("--out is empty: give the sweep directory");
      if (o->spec.empty() || o->out.empty())
        throw Error("usage: ccfr sweep SPEC.yaml --out DIR (or status/resume/collect DIR)");
      return start_sweep(o->spec, o->out, o->run);
    });
  });
}

}  // namespace ccfr::app
