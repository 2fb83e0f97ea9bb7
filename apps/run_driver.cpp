#include "run_driver.hpp"

#include <atomic>
#include <chrono>
#include <optional>
#include <csignal>
#include <cstdio>

#include "audit_hook.hpp"
#include "progress.hpp"
#include "scene_advice.hpp"
#include "ccfr/core/error.hpp"
#include "ccfr/core/log.hpp"
#include "ccfr/core/parallel.hpp"
#include "ccfr/io/output.hpp"
#include "ccfr/io/scene_loader.hpp"

namespace ccfr::app {

namespace {
// The signal that asked the run to stop (SIGINT or SIGTERM), 0 while none did. The frame being
// computed is finished and written before the run stops.
std::atomic<int> g_stop_signal{0};
extern "C" void on_stop_signal(int sig) { g_stop_signal = sig; }

std::vector<std::string>& invocation() {
  static std::vector<std::string> argv;
  return argv;
}

// Quotes an argument for a POSIX shell when it needs it, so that command_line can be pasted back.
std::string shell_quote(const std::string& a) {
  if (!a.empty() && a.find_first_not_of("ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789_-+=./:,@%") ==
                        std::string::npos)
    return a;
  std::string o = "'";
  for (char c : a) o += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return o + "'";
}

// Installs the stop handlers for the run and restores the previous ones however it ends. SIGXFSZ
// is ignored so that a file-size limit fails the write (EFBIG, reported) instead of killing us.
class SignalScope {
 public:
  SignalScope() {
    g_stop_signal = 0;
    int_ = std::signal(SIGINT, on_stop_signal);
    term_ = std::signal(SIGTERM, on_stop_signal);
    xfsz_ = std::signal(SIGXFSZ, SIG_IGN);
  }
  ~SignalScope() {
    std::signal(SIGINT, int_);
    std::signal(SIGTERM, term_);
    std::signal(SIGXFSZ, xfsz_);
  }
  SignalScope(const SignalScope&) = delete;
  SignalScope& operator=(const SignalScope&) = delete;

 private:
  using Handler = void (*)(int);
  Handler int_, term_, xfsz_;
};

}  // namespace

void set_invocation(int argc, const char* const* argv) {
  invocation().assign(argv, argv + argc);
  if (!invocation().empty()) invocation()[0] = "ccfr";  // the program as typed may be a build path
}

const std::vector<std::string>& invocation_argv() { return invocation(); }

std::string invocation_string() {
  std::string s;
  for (const auto& a : invocation()) s += (s.empty() ? "" : " ") + shell_quote(a);
  return s;
}

void add_run_options(CLI::App* cmd, RunOptions& opts) {
  cmd->add_option("--frames", opts.frames, "Frames to simulate (default: time.frames of the scene)")
      ->check(CLI::NonNegativeNumber);
  cmd->add_option("--solver", opts.solver, "Contact solver (overrides contact.solver)");
  cmd->add_option("--set", opts.overrides,
                  "Override a scene key: key.path=value (repeatable), e.g. --set contact.radius=0.01");
  cmd->add_option("--threads", opts.threads, "Worker threads (default: all cores)")->check(CLI::NonNegativeNumber);
}

RunSummary run_scene(const RunOptions& opts) {
  std::vector<std::string> overrides = opts.overrides;
  if (opts.frames >= 0) overrides.push_back("time.frames=" + std::to_string(opts.frames));
  if (!opts.solver.empty()) overrides.push_back("contact.solver=" + opts.solver);
  set_thread_count(opts.threads);

  io::LoadedScene loaded = io::load_scene(opts.config, overrides);
  if (opts.advise)
    for (const std::string& advice : scene_advice(loaded.scene)) spdlog::warn("{}", advice);
  const SimulationParams params = loaded.scene.params;
  RunSummary summary;
  summary.out = opts.out;
  summary.offset = params.contact.offset;
  summary.solver = params.contact.solver;
  summary.vertices = loaded.scene.topo.num_vertices();
  summary.substeps = params.time.substeps;
  summary.iterations = params.time.iterations;
  summary.violations_opted_out = params.contact.on_violation == ViolationPolicy::warn;

  Simulation sim(std::move(loaded.scene));
  if (params.debug.audit != AuditMode::off) sim.set_audit(make_audit_hook(sim.topology(), sim.positions(), params));

  // Stop at once on a failed write (full disk, file-size limit, I/O error): the frame or row that
  // failed is not on disk, every earlier one is whole, and run.json says which file failed.
  auto output_failed = [&summary](const Error& e) {
    summary.status = std::string("failed: ") + e.what();
    summary.failed = true;
    spdlog::error("{}", e.what());
  };
  SignalScope signals;
  std::unique_ptr<io::RunWriter> writer;
  if (!opts.out.empty()) {
    io::RunMeta meta{params.scene_name,
                     params.contact.solver,
                     params.collision.broad_phase,
                     params.contact.radius,
                     params.contact.offset,
                     params.contact.repulsion_range,
                     params.time.fps,
                     thread_count(),
                     opts.command_line,
                     opts.argv,
                     std::nullopt};
    if (const CollisionDetector* det = sim.contact_solver().collision_detector())
      meta.initial_proximity = det->initial_proximity();
    writer = std::make_unique<io::RunWriter>(opts.out, sim.topology(), loaded.resolved_json, meta, opts.force);
    try {
      writer->start();
      if (params.output.frames) writer->write_frame(0, sim.positions());
    } catch (const Error& e) {
      output_failed(e);
    }
  }
  const int total = params.time.frames;
  std::optional<ProgressReporter> progress;
  if (opts.progress) progress.emplace(opts.progress_label, total);
  const auto started = std::chrono::steady_clock::now();
  for (int f = 1; f <= total && !summary.failed; ++f) {
    if (const int sig = g_stop_signal) {
      summary.status =
          (sig == SIGTERM ? "terminated after frame " : "interrupted after frame ") + std::to_string(f - 1);
      if (sig == SIGTERM) summary.status += " (SIGTERM)";
      summary.failed = true;
      spdlog::warn("{}", summary.status);
      break;
    }
    FrameStats fs;
    try {
      fs = sim.step_frame();
    } catch (const Error& e) {
      // Non-finite positions, a broken guarantee, scripted motion beyond the bound: the frame
      // being computed is not written; every frame on disk stays whole and clean.
      summary.status = std::string("failed: ") + e.what();
      summary.failed = true;
      spdlog::error("{}", e.what());
      break;
    }
    summary.frames.push_back(fs);
    if (fs.violations_remaining > 0 || fs.penetrations > 0) ++summary.violated_frames;
    if (writer) {
      try {
        if (params.output.frames && (f % params.output.every == 0 || f == total))
          writer->write_frame(f, sim.positions());
        writer->write_stats(fs);
      } catch (const Error& e) {
        output_failed(e);
        break;
      }
    }
    if (progress && progress->on_terminal())
      progress->update(f, fmt::format("{:.3f} s/frame  viol {}/{}  halted {}", fs.wall_s, fs.violations_detected,
                                      fs.violations_remaining, fs.halted_vertices));
    else if (progress)
      progress->update(
          f, fmt::format("{:.3f} s (xpbd {:.3f}, broad {:.3f}, narrow {:.3f}, resolution {:.3f}); violations {}/{}; "
                         "halted {}{}",
                         fs.wall_s, fs.times.xpbd, fs.times.broad, fs.times.narrow, fs.times.resolution,
                         fs.violations_detected, fs.violations_remaining, fs.halted_vertices,
                         fs.penetrations >= 0 ? "; penetrations " + std::to_string(fs.penetrations) : std::string()));
  }
  if (progress) progress->finish();
  summary.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  if (writer) {
    try {
      writer->finish(summary.status);
    } catch (const Error& e) {
      // run.json could not be rewritten (the disk is still full): the last one written says
      // "running" with the frames on disk, which is what the audit expects of a killed run.
      output_failed(e);
    }
    summary.previous_kept = writer->discarded();
  }
  return summary;
}

}  // namespace ccfr::app
