// `ccfr run CONFIG`: simulate a scene and write the output directory of the contract.
#include <filesystem>

#include "ccfr/core/error.hpp"
#include "ccfr/core/log.hpp"
#include "commands.hpp"
#include "run_driver.hpp"

namespace ccfr::app {

void register_run(CLI::App& app) {
  auto opts = std::make_shared<RunOptions>();
  auto log_level = std::make_shared<std::string>("info");
  auto* cmd = app.add_subcommand("run", "Simulate a scene file and write run.json, frames/ and stats.csv");
  cmd->add_option("config", opts->config, "Scene file (YAML); not with --resume");
  cmd->add_option("--out", opts->out, "Output directory (default: out/<scene file name>)");
  cmd->add_flag("--force", opts->force,
                "Write into --out even if it is a non-empty directory that is not a ccfr run (its other files stay)");
  add_run_options(cmd, *opts);
  cmd->add_option("--resume", opts->resume,
                  "Continue the run in this directory from its latest checkpoint (output.checkpoint_every); only "
                  "--threads and --log-level may be given with it");
  cmd->add_option("--log-level", *log_level, "trace, debug, info, warn, error or off")
      ->check(CLI::IsMember({"trace", "debug", "info", "warn", "error", "off"}));
  cmd->callback([opts, log_level, &app] {
    init_logging(*log_level);
    guarded([&] {
      if (!opts->resume.empty()) {
        // The checkpoint carries the configuration: anything that would change it is refused.
        if (!opts->config.empty() || !opts->out.empty() || opts->frames >= 0 || !opts->solver.empty() ||
            !opts->overrides.empty() || opts->force)
          throw Error("--resume continues a run exactly as it was configured: give it alone (with --threads or "
                      "--log-level), without a scene file, --out, --frames, --solver, --set or --force");
      } else if (opts->config.empty()) {
        throw Error("a scene file is required (or --resume DIR)");
      }
      if (opts->out.empty() && opts->resume.empty()) opts->out = std::filesystem::path("out") / opts->config.stem();
      opts->command_line = invocation_string();
      opts->argv = invocation_argv();
      const RunSummary s = run_scene(*opts);
      if (s.nothing_to_resume) {
        std::fprintf(stderr, "nothing to resume: %s has completed\n",
                     std::filesystem::absolute(s.out).string().c_str());
        return 0;
      }
      if (s.previous_kept)
        std::fprintf(stderr, "%s: %zu frames; output discarded, the previous run in %s was kept\n", s.status.c_str(),
                     s.frames.size(), std::filesystem::absolute(s.out).string().c_str());
      else if (s.resumed_after >= 0)
        std::fprintf(stderr, "%s: resumed after frame %d, %zu more frames, output in %s\n", s.status.c_str(),
                     s.resumed_after, s.frames.size(), std::filesystem::absolute(s.out).string().c_str());
      else
        std::fprintf(stderr, "%s: %zu frames, output in %s\n", s.status.c_str(), s.frames.size(),
                     std::filesystem::absolute(s.out).string().c_str());
      if (s.failed) return 1;
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
