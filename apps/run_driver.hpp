#pragma once
// Running one scene into an output directory: shared by `ccfr run`, `ccfr ablate` and `ccfr bench`.
#include <filesystem>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "ccfr/solvers/simulation.hpp"

namespace ccfr::app {

struct RunOptions {
  std::filesystem::path config;
  std::filesystem::path out;             ///< empty: no output directory (bench)
  int frames = -1;                       ///< -1: from the scene
  std::string solver;                    ///< empty: from the scene
  double max_memory = -1;                ///< --max-memory GB (overrides max_memory); < 0: from the scene
  std::vector<std::string> overrides;    ///< --set key.path=value
  int threads = 0;                       ///< 0: all hardware threads
  bool progress = true;                  ///< per-frame progress with ETA (progress.hpp) unless --quiet
  std::string progress_label = "frame";  ///< starts each progress line
  bool advise = false;                   ///< warn about r, ξ, speeds out of range (scene_advice.hpp)
  std::string command_line;              ///< run.json `command_line`
  std::vector<std::string> argv;         ///< run.json `argv` (every argument as typed); empty: omitted
  bool force = false;                    ///< --force: write into a non-empty directory that is not a ccfr run
  /// --resume DIR: continue the run in DIR from its latest checkpoint (config, overrides, frames
  /// and solver come from the checkpoint; `config` and `out` are ignored).
  std::filesystem::path resume;
  /// Wall seconds of simulation after which the run stops at the end of its frame, like a signal
  /// (checkpoint, status "stopped at its time limit ..."), but is audited; 0: none (sweep cells).
  double time_limit_s = 0.0;
};

struct RunSummary {
  std::vector<FrameStats> frames;
  std::string status = "completed";
  bool failed = false;
  std::filesystem::path out;
  double offset = 0.0;
  std::string solver;
  Index vertices = 0;
  int substeps = 0, iterations = 0;
  double wall_s = 0.0;  ///< wall-clock time of the frame loop
  /// Frames that ended with violations remaining or audit penetrations, which the run went on
  /// past (contact.on_violation = warn, or auto under a solver without the guarantee).
  size_t violated_frames = 0;
  bool violations_opted_out = false;  ///< contact.on_violation was set to warn explicitly
  /// The run stopped before its first simulated frame while rerunning into an existing run
  /// directory: its output was discarded and the previous run left as it was.
  bool previous_kept = false;
  int resumed_after = -1;          ///< --resume: the checkpoint's frame; -1 for a fresh run
  bool nothing_to_resume = false;  ///< --resume of a run that had already completed
  int last_checkpoint = -1;        ///< frame of the last checkpoint written (-1: none)
  int stop_signal = 0;             ///< SIGINT or SIGTERM when a signal stopped the run, else 0
  bool time_limited = false;       ///< RunOptions::time_limit_s stopped the run
  /// The run is in place but the previous run's files could not all be removed (where they are
  /// and why); the exit code is then non-zero.
  std::string cleanup_error;
};

/// Quotes an argument for a POSIX shell when it needs it, so that a command can be pasted back.
std::string shell_quote(const std::string& a);

/// Loads, simulates and (if opts.out is set) writes the run. Numerical failures end the run with
/// `failed` set and the frames so far kept; configuration errors throw ccfr::Error.
RunSummary run_scene(const RunOptions& opts);

/// The exit code of `ccfr run` for a run that ended this way (docs/output.md): 0, 1 (stopped
/// early, or the previous run's files could not be removed), 3 (completed with violations under a
/// solver without the guarantee).
int run_exit_code(const RunSummary& s);

/// Records the process's arguments (from main) for run.json: argv[0] is recorded as "ccfr".
void set_invocation(int argc, const char* const* argv);
const std::vector<std::string>& invocation_argv();
/// The recorded arguments joined by spaces, each quoted for a POSIX shell where needed.
std::string invocation_string();

/// Adds --frames, --solver, --set and --threads to a subcommand.
void add_run_options(CLI::App* cmd, RunOptions& opts);

}  // namespace ccfr::app
