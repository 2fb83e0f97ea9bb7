// `ccfr run CONFIG`: simulate a scene and write the output directory of the contract.
#include <algorithm>
#include <cstdio>
#include <filesystem>

#include "ccfr/core/error.hpp"
#include "ccfr/core/log.hpp"
#include "ccfr/io/checkpoint.hpp"
#include "commands.hpp"
#include "progress.hpp"
#include "run_driver.hpp"

namespace ccfr::app {

namespace {

// What to run after this run: a completed one is audited; one stopped by a signal is continued
// from its checkpoint (`ccfr audit` of it exits 4, not completed), or run again if it has none; any
// other stop leaves frames whose audit needs --partial.
std::string next_command(const RunSummary& s, const std::string& dir) {
  const std::string q = shell_quote(dir);
  if (!s.failed) return "ccfr audit " + q;
  if (s.stop_signal != 0) {
    if (io::latest_checkpoint(s.out)) return "ccfr run --resume " + q;
    return invocation_string() + "  (again: no checkpoint to resume from)";
  }
  return "ccfr audit --partial " + q;
}

// The closing summary on stdout: where the output went, how long it took, what is left to
// check, and the command that checks it.
void print_summary(const RunSummary& s) {
  const std::string dir = std::filesystem::absolute(s.out).string();
  if (s.previous_kept) {
    std::printf("%s: %zu frames; output discarded, the previous run in %s was kept\n", s.status.c_str(),
                s.frames.size(), dir.c_str());
    return;
  }
  if (s.resumed_after >= 0)
    std::printf("%s: resumed after frame %d, %zu more frames, output in %s\n", s.status.c_str(), s.resumed_after,
                s.frames.size(), dir.c_str());
  else
    std::printf("%s: %zu frames, output in %s\n", s.status.c_str(), s.frames.size(), dir.c_str());
  long detected = 0, remaining_frames = 0, remaining_max = 0, halted = 0, penetrations = 0;
  bool audited = false;
  for (const FrameStats& f : s.frames) {
    detected += f.violations_detected;
    remaining_frames += f.violations_remaining > 0;
    remaining_max = std::max<long>(remaining_max, f.violations_remaining);
    halted += f.halted_vertices;
    if (f.penetrations >= 0) audited = true, penetrations += f.penetrations;
  }
  const double per_frame = s.frames.empty() ? 0.0 : s.wall_s / static_cast<double>(s.frames.size());
  std::printf("  time: %s (%.3f s/frame); solver %s, %d vertices, %d substeps x %d iterations\n",
              format_duration(s.wall_s).c_str(), per_frame, s.solver.c_str(), s.vertices, s.substeps, s.iterations);
  std::printf(
      "  contact: %ld violations detected; %ld frames left violations after a substep (at most %ld); %ld "
      "vertex halts",
      detected, remaining_frames, remaining_max, halted);
  if (audited) std::printf(", %ld penetrations found by debug.audit", penetrations);
  std::printf("\n  next: %s\n", next_command(s, dir).c_str());
  std::fflush(stdout);
}

}  // namespace

void register_run(CLI::App& app) {
  auto opts = std::make_shared<RunOptions>();
  auto* cmd = app.add_subcommand("run", "Simulate a scene file and write run.json, frames/ and stats.csv");
  cmd->add_option("config", opts->config, "Scene file (YAML); not with --resume");
  cmd->add_option("--out", opts->out, "Output directory (default: out/<scene file name>)");
  cmd->add_flag("--force", opts->force,
                "Write into --out even if it is a non-empty directory that is not a ccfr run (its other files stay)");
  add_run_options(cmd, *opts);
  cmd->add_option("--resume", opts->resume,
                  "Continue the run in this directory from its latest checkpoint (output.checkpoint_every); only "
                  "--threads and --log-level may be given with it");
  cmd->callback([opts, cmd] {
    init_logging("info");
    guarded([&] {
      // `--out ""` (an unset shell variable) must not fall back to the default folder and replace the run there.
      if (cmd->count("--out") > 0 && opts->out.empty()) throw Error("--out is empty: give the output directory");
      if (cmd->count("--resume") > 0 && opts->resume.empty())
        throw Error("--resume is empty: give the run directory to continue");
      if (!opts->resume.empty()) {
        // The checkpoint carries the configuration: anything that would change it is refused.
        if (!opts->config.empty() || !opts->out.empty() || opts->frames >= 0 || !opts->solver.empty() ||
            opts->max_memory >= 0 || !opts->overrides.empty() || opts->force)
          throw Error(
              "--resume continues a run exactly as it was configured: give it alone (with --threads or "
              "--log-level), without a scene file, --out, --frames, --solver, --max-memory, --set or --force");
      } else if (opts->config.empty()) {
        throw Error("a scene file is required (or --resume DIR)");
      }
      if (opts->out.empty() && opts->resume.empty()) opts->out = std::filesystem::path("out") / opts->config.stem();
      opts->command_line = invocation_string();
      opts->argv = invocation_argv();
      opts->advise = true;
      const RunSummary s = run_scene(*opts);
      if (s.nothing_to_resume) {
        std::printf("nothing to resume: %s has completed\n", std::filesystem::absolute(s.out).string().c_str());
        return 0;
      }
      print_summary(s);
      if (!s.cleanup_error.empty()) std::fprintf(stderr, "error: %s\n", s.cleanup_error.c_str());
      if (s.failed || !s.cleanup_error.empty()) return 1;
      if (s.violated_frames > 0 && !s.violations_opted_out) {
        // A baseline without the guarantee ran to the end (contact.on_violation: auto); its
        // frames are kept for comparison, but the run is not a clean one.
        std::fprintf(stderr,
                     "%zu frame(s) ended with violations remaining under contact solver '%s', which does not guarantee "
                     "separation; exit 3 (set contact.on_violation: warn to accept)\n",
                     s.violated_frames, s.solver.c_str());
        return 3;
      }
      return 0;
    });
  });
}

}  // namespace ccfr::app
