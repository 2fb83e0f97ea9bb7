#include "run_driver.hpp"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <optional>

#include <spdlog/spdlog.h>
#include <nlohmann/json.hpp>

#include "ccfr/core/error.hpp"
#include "ccfr/core/log.hpp"
#include "ccfr/core/parallel.hpp"
#include "ccfr/core/process.hpp"
#include "ccfr/geometry_exact/audit.hpp"
#include "ccfr/io/checkpoint.hpp"
#include "ccfr/io/dir_lock.hpp"
#include "ccfr/io/obj.hpp"
#include "ccfr/io/run_json.hpp"
#include "ccfr/io/run_recorder.hpp"
#include "ccfr/io/scene_loader.hpp"
#include "progress.hpp"
#include "scene_advice.hpp"

namespace ccfr::app {

namespace {
// The signal that asked the run to stop (SIGINT or SIGTERM), 0 while none did. The frame being
// computed is finished and written before the run stops.
std::atomic<int> g_stop_signal{0};
std::atomic<int> g_stop_count{0};  // signals received: a second one abandons the frame in progress
extern "C" void on_stop_signal(int sig) {
  g_stop_signal = sig;
  ++g_stop_count;
}
/// Seconds a frame in progress may still run after the first stop signal before it is abandoned.
constexpr double kStopGraceS = 10.0;

std::vector<std::string>& invocation() {
  static std::vector<std::string> argv;
  return argv;
}

// Installs the stop handlers for the run and restores the previous ones however it ends. SIGXFSZ
// is ignored so that a file-size limit fails the write (EFBIG, reported) instead of killing us.
class SignalScope {
 public:
  SignalScope() {
    g_stop_signal = 0;
    g_stop_count = 0;
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

std::string shell_quote(const std::string& a) {
  if (!a.empty() && a.find_first_not_of("ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789_-+=./:,@%") ==
                        std::string::npos)
    return a;
  std::string o = "'";
  for (char c : a) o += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return o + "'";
}

int run_exit_code(const RunSummary& s) {
  if (s.nothing_to_resume) return 0;
  if (s.failed || !s.cleanup_error.empty()) return 1;
  if (s.violated_frames > 0 && !s.violations_opted_out) return 3;
  return 0;
}

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
      ->check(CLI::Validator(
          [](std::string& in) {
            long long v = 0;
            if (!CLI::detail::lexical_cast(in, v) || v < 0 || v > io::kMaxFrames)
              return "Value " + in + " out of range: must be an integer >= 0 and at most " +
                     std::to_string(io::kMaxFrames) + " (time.frames' bound)";
            return std::string();
          },
          "INT in [0, 1e7]", "frames"));
  cmd->add_option("--solver", opts.solver, "Contact solver (overrides contact.solver)");
  cmd->add_option("--set", opts.overrides,
                  "Override a scene key: key.path=value (repeatable), e.g. --set contact.radius=0.01; a map value "
                  "merges key by key (--set 'time={frames: 3}' keeps the other time keys)");
  cmd->add_option("--max-memory", opts.max_memory,
                  "Largest estimated memory (GB) the scene may need to load (overrides max_memory; default: what "
                  "the machine has available). Raise it knowingly: a scene above the machine's memory is OOM-killed")
      ->check(CLI::Validator(
          [](std::string& in) {
            // max_memory's range; below a megabyte no scene loads, so a tiny value is a typo (not 0).
            double v = 0;
            if (!CLI::detail::lexical_cast(in, v) || !(v == 0 || (v >= 1e-3 && v <= 1e6)))
              return "Value " + in + " out of range: give GB in [0.001, 1000000], or 0 for what the machine has";
            return std::string();
          },
          "GB", "max memory"));
  cmd->add_option("--threads", opts.threads, "Worker threads (default: all cores)")->check(CLI::NonNegativeNumber);
}

namespace {
// The checkpoint to resume from, checked against the scene it names as it is now.
struct Resume {
  io::Checkpoint ckpt;
  std::filesystem::path file;
};

Resume load_resume(const std::filesystem::path& dir) {
  if (!io::is_ccfr_run(dir))
    throw Error("cannot resume '" + dir.string() + "': not a ccfr run directory (" + io::run_json_problem(dir) + ")");
  const auto latest = io::latest_checkpoint(dir);
  if (!latest)
    throw Error("cannot resume '" + dir.string() + "': no checkpoint in '" + (dir / "checkpoints").string() +
                "' (output.checkpoint_every was 0, or the run stopped before its first checkpoint); run it again");
  Resume r{io::read_checkpoint(*latest), *latest};
  if (r.ckpt.ccfr_version != io::version() || r.ckpt.git_commit != io::git_commit())
    throw Error("checkpoint '" + latest->string() + "' was written by ccfr " + r.ckpt.ccfr_version + " (commit " +
                r.ckpt.git_commit + "), this is ccfr " + io::version() + " (commit " + io::git_commit() +
                "): the resumed run would not match an uninterrupted one; resume with that build or run again");
  // The checkpoint must be this run's: a checkpoint copied from another run names its own scene
  // and matches it, so it is checked against what DIR/run.json says this run is.
  std::ifstream in(dir / "run.json");
  const nlohmann::json run = nlohmann::json::parse(in, nullptr, /*allow_exceptions=*/false);
  const std::string foreign = "checkpoint '" + latest->string() + "' does not belong to the run in '" + dir.string() +
                              "' (copied from another run?): ";
  if (run.is_object() && run.contains("scene_fingerprint") && run["scene_fingerprint"].is_string()) {
    const std::string mine = run["scene_fingerprint"].get<std::string>();
    const std::string theirs = fmt::format("{:016x}", r.ckpt.scene_fingerprint);
    if (mine != theirs) throw Error(foreign + "its scene fingerprint is " + theirs + ", run.json records " + mine);
  }
  if (run.is_object() && run.contains("config")) {
    const std::string diff = io::json_difference(run["config"].dump(), r.ckpt.resolved_config);
    if (!diff.empty()) throw Error(foreign + "run.json's config and the checkpoint's differ at " + diff);
  }
  return r;
}

// Every frame the run wrote up to the checkpoint must be on disk and readable, and the checkpoint's
// own frame must hold its positions: a resumed run continues the frames on disk, so a missing or
// foreign frame there would be a gap in the finished sequence that no one notices.
void check_frames_before(const std::filesystem::path& dir, const Resume& r, const OutputParams& out) {
  if (!out.frames) return;
  if (!out.formats.empty() && std::find(out.formats.begin(), out.formats.end(), "obj") == out.formats.end()) return;
  const int every = std::max(1, out.every);
  std::vector<int> missing;
  std::string unreadable;
  for (int f = 0; f <= r.ckpt.sim.frame; f += every) {
    const std::filesystem::path p = dir / "frames" / fmt::format("frame_{:05d}.obj", f);
    std::error_code ec;
    if (!std::filesystem::is_regular_file(p, ec)) {
      missing.push_back(f);
      continue;
    }
    std::ifstream fin(p);
    std::string header;
    if (unreadable.empty() && (!fin || !std::getline(fin, header) || header.rfind("# ccfr frame", 0) != 0))
      unreadable = p.string();
  }
  const std::string why = "cannot resume '" + dir.string() + "' from '" + r.file.string() + "' (frame " +
                          std::to_string(r.ckpt.sim.frame) + "): ";
  if (!missing.empty()) {
    std::string list;
    for (size_t i = 0; i < missing.size() && i < 20; ++i) list += (i ? ", " : "") + std::to_string(missing[i]);
    if (missing.size() > 20) list += " and " + std::to_string(missing.size() - 20) + " more";
    throw Error(why + std::to_string(missing.size()) + " of the frames it follows " +
                (missing.size() == 1 ? "is" : "are") + " missing from '" + (dir / "frames").string() + "' (" + list +
                "); the finished run would have a gap: restore them or run again");
  }
  if (!unreadable.empty())
    throw Error(why + "'" + unreadable + "' cannot be read as a ccfr frame; restore it or run again");
  if (r.ckpt.sim.frame % every == 0) {
    const std::filesystem::path p = dir / "frames" / fmt::format("frame_{:05d}.obj", r.ckpt.sim.frame);
    io::Frame fr;
    try {
      fr = io::read_frame_obj(p);
    } catch (const Error& e) {
      throw Error(why + e.what());
    }
    if (fr.v != r.ckpt.sim.x)
      throw Error(why + "'" + p.string() + "' does not hold the checkpoint's positions (" +
                  std::to_string(fr.v.size()) + " vertices on disk, " + std::to_string(r.ckpt.sim.x.size()) +
                  " in the checkpoint): frame and checkpoint come from different runs");
  }
}

std::string gigabytes(double bytes) {
  return bytes >= 1e9 ? fmt::format("{:.1f} GB", bytes / 1e9) : fmt::format("{:.0f} MB", bytes / 1e6);
}

// Why a run stopped for memory, and what to do about it (docs/output.md, exit codes).
std::string memory_stop_message(int frame, double held, const io::MemoryEstimate& m) {
  return "memory: the run holds " + gigabytes(held) + " after frame " + std::to_string(frame) + ", more than the " +
         gigabytes(m.limit_bytes) +
         (m.limit_from_environment ? " of CCFR_RUN_MEMORY_LIMIT_MB"
          : m.limit_is_max_memory  ? " of max_memory"
                                   : " the machine had for it when it started") +
         " (the loader estimated " + gigabytes(m.total_bytes) +
         "); every frame so far is whole. Contact memory grows with the pairs in range: raise max_memory "
         "(or --max-memory) if the machine has more, or coarsen the meshes, or lower contact.offset and "
         "contact.radius (docs/choosing-parameters.md, Memory)";
}

/// The overrides the run's scene loads with: a resumed run's are its checkpoint's.
std::vector<std::string> run_overrides(const RunOptions& opts, const std::optional<Resume>& resume) {
  std::vector<std::string> overrides = resume ? resume->ckpt.overrides : opts.overrides;
  if (!resume && opts.frames >= 0) overrides.push_back("time.frames=" + std::to_string(opts.frames));
  if (!resume && !opts.solver.empty()) overrides.push_back("contact.solver=" + opts.solver);
  if (!resume && opts.max_memory >= 0) overrides.push_back(ccfr::format("max_memory={}", opts.max_memory));
  return overrides;
}

/// The scene at `config`; with `resume`, checked to be the scene its checkpoint was written from.
io::LoadedScene load_run_scene(const std::filesystem::path& config, const std::vector<std::string>& overrides,
                               const std::optional<Resume>& resume) {
  io::LoadedScene loaded = [&] {
    if (!resume) return io::load_scene(config, overrides);
    try {
      return io::load_scene(config, overrides);
    } catch (const Error& e) {
      throw Error("cannot resume from '" + resume->file.string() + "': its scene no longer loads: " + e.what());
    }
  }();
  if (resume) {
    const std::string diff = io::json_difference(resume->ckpt.resolved_config, loaded.resolved_json);
    if (!diff.empty())
      throw Error("checkpoint '" + resume->file.string() + "' does not match its scene '" + config.string() +
                  "' as it is now: " + diff);
    const std::uint64_t fp = io::scene_fingerprint(loaded.scene.topo, loaded.scene.state);
    if (fp != resume->ckpt.scene_fingerprint)
      throw Error("checkpoint '" + resume->file.string() + "' does not match its scene '" + config.string() +
                  "': the meshes or initial positions changed since it was written (fingerprint " +
                  fmt::format("{:016x}", resume->ckpt.scene_fingerprint) + ", now " + fmt::format("{:016x}", fp) + ")");
  }
  return loaded;
}

/// The summary's description of the run before its first frame.
RunSummary start_summary(const RunOptions& opts, const SimulationParams& params, Index vertices, bool resumed) {
  RunSummary summary;
  summary.out = resumed ? opts.resume : opts.out;
  summary.offset = params.contact.offset;
  summary.solver = params.contact.solver;
  summary.vertices = vertices;
  summary.substeps = params.time.substeps;
  summary.iterations = params.time.iterations;
  summary.violations_opted_out = params.contact.on_violation == ViolationPolicy::warn;
  return summary;
}

/// Whether the resumed run has frames left (false: it had completed, and `summary` says so);
/// throws when the checkpoint's frame is out of range or the frames before it are not on disk.
bool frames_left_to_resume(const RunOptions& opts, const Resume& resume, const SimulationParams& params,
                           RunSummary& summary) {
  // Before anything counts frames up to it (a hand-edited frame 2147483647 stat-ed files for hours).
  if (const int at = resume.ckpt.sim.frame; at < 0 || at > params.time.frames)
    throw Error("checkpoint '" + resume.file.string() + "' is at frame " + std::to_string(at) +
                (at < 0 ? ", not a frame" : ", beyond the run's " + std::to_string(params.time.frames) + " frames"));
  const io::RunInfo info = io::read_run_info(opts.resume);
  if (info.progress.status == "completed") {
    summary.nothing_to_resume = true;
    summary.resumed_after = resume.ckpt.sim.frame;
    return false;
  }
  check_frames_before(opts.resume, resume, params.output);
  return true;
}

/// A second stop signal, or kStopGraceS after the first, abandons the frame in progress.
void cancel_on_stop_signals(Simulation& sim) {
  sim.set_cancel([first = std::optional<std::chrono::steady_clock::time_point>()]() mutable {
    if (g_stop_count == 0) return false;
    if (g_stop_count >= 2) return true;
    const auto now = std::chrono::steady_clock::now();
    if (!first) first = now;
    return std::chrono::duration<double>(now - *first).count() >= kStopGraceS;
  });
}

/// Restores the simulation and the audit from the checkpoint; returns the first frame to run.
int restore_from(const Resume& resume, const RunOptions& opts, Simulation& sim, exact::PenetrationAudit* audit,
                 RunSummary& summary) {
  const io::Checkpoint& c = resume.ckpt;
  try {
    sim.restore(c.sim);
    if (audit)
      audit->restore_reduced_offsets(c.audit_offsets);
    else if (!c.audit_offsets.empty())
      throw Error("it holds audit state, but debug.audit is off");
  } catch (const Error& e) {
    throw Error("checkpoint '" + resume.file.string() + "' does not fit its scene: " + e.what());
  }
  summary.resumed_after = c.sim.frame;
  summary.violated_frames = static_cast<size_t>(c.violated_frames);
  spdlog::info("resuming '{}' after frame {} from '{}'", opts.resume.string(), c.sim.frame, resume.file.string());
  return c.sim.frame + 1;
}

/// The memory the run is held to: the limit the scene was loaded under; CCFR_RUN_MEMORY_LIMIT_MB
/// lowers it for this run only (the tests of the stop use it: no scene of theirs is estimated low).
io::MemoryEstimate run_memory_limit(const io::MemoryEstimate& loaded) {
  io::MemoryEstimate run_limit = loaded;
  if (const char* cap = std::getenv("CCFR_RUN_MEMORY_LIMIT_MB"); cap && std::atof(cap) > 0) {
    const double b = std::atof(cap) * 1e6;
    run_limit.limit_bytes = run_limit.limit_bytes > 0 ? std::min(run_limit.limit_bytes, b) : b;
    run_limit.limit_is_max_memory = false;
    run_limit.limit_from_environment = true;
  }
  return run_limit;
}

/// What a run is, as its checkpoints record it.
struct RunIdentity {
  const io::LoadedScene& loaded;  ///< its resolved config and memory estimate (the scene is moved out)
  const std::filesystem::path& config;
  const std::vector<std::string>& overrides;
  std::uint64_t fingerprint = 0;
};

/// The frame loop of a run: frames, their output and checkpoints, stops and progress, all
/// recorded in the run's summary.
class FrameLoop {
 public:
  FrameLoop(const RunOptions& opts, const SimulationParams& params, const RunIdentity& id, Simulation& sim,
            const exact::PenetrationAudit* audit, bool resumed, int first_frame, RunSummary& summary)
      : opts_(opts),
        params_(params),
        id_(id),
        sim_(sim),
        audit_(audit),
        resumed_(resumed),
        first_frame_(first_frame),
        summary_(summary) {}

  /// Runs the frames from the first to the scene's last, or until the run stops or fails.
  void run() {
    open_writer();
    const int total = params_.time.frames;
    const io::MemoryEstimate run_limit = run_memory_limit(id_.loaded.memory);
    // With --resume, progress and ETA count the frames still to run.
    if (opts_.progress) progress_.emplace(opts_.progress_label, total - first_frame_ + 1);
    started_ = std::chrono::steady_clock::now();
    for (int f = first_frame_; f <= total && !summary_.failed; ++f)
      if (stopped_before(f) || !step(f, total, run_limit)) break;
    if (progress_) progress_->finish();
    summary_.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - started_).count();
    if (writer_) {
      try {
        writer_->finish(summary_.status);
      } catch (const Error& e) {
        // run.json could not be rewritten (the disk is still full): the last one written says
        // "running" with the frames on disk, which is what the audit expects of a killed run.
        output_failed(e);
      }
      summary_.previous_kept = writer_->writer().discarded();
      summary_.cleanup_error = writer_->writer().cleanup_error();
    }
  }

 private:
  // Stop at once on a failed write (full disk, file-size limit, I/O error): the frame or row that
  // failed is not on disk, every earlier one is whole, and run.json says which file failed.
  void output_failed(const Error& e) {
    summary_.status = std::string("failed: ") + e.what();
    summary_.failed = true;
    spdlog::error("{}", e.what());
  }

  void open_writer() {
    if (opts_.out.empty() && !resumed_) return;
    io::RunMeta meta = io::make_run_meta(sim_, opts_.command_line, opts_.argv);
    meta.scene_fingerprint = id_.fingerprint;
    meta.memory_estimate = id_.loaded.memory.total_bytes;
    meta.memory_limit = id_.loaded.memory.limit_bytes;
    const int frames = params_.time.frames;
    writer_ = resumed_
                  ? std::make_unique<io::RunRecorder>(opts_.resume, sim_, id_.loaded.resolved_json, std::move(meta),
                                                      frames, io::RunWriter::ResumeAt{first_frame_ - 1})
                  : std::make_unique<io::RunRecorder>(opts_.out, sim_, id_.loaded.resolved_json, std::move(meta),
                                                      frames, opts_.force);
    try {
      writer_->start();
    } catch (const Error& e) {
      output_failed(e);
    }
  }

  /// A checkpoint of the state after the frames done so far, next to the frames (docs/output.md).
  void save_checkpoint() {
    io::Checkpoint c;
    c.sim = sim_.checkpoint();
    c.ccfr_version = io::version();
    c.git_commit = io::git_commit();
    c.resolved_config = id_.loaded.resolved_json;
    c.scene_file = std::filesystem::absolute(id_.config).lexically_normal();
    c.overrides = id_.overrides;
    c.scene_fingerprint = id_.fingerprint;
    if (audit_) c.audit_offsets = audit_->reduced_offsets();
    c.violated_frames = static_cast<std::int64_t>(summary_.violated_frames);
    c.frames_written = writer_->writer().frames_written();
    io::write_checkpoint(writer_->writer().dir(), c);
    summary_.last_checkpoint = c.sim.frame;
  }

  /// A checkpoint whose failure is reported but does not change how the run ends.
  void try_save_checkpoint() {
    try {
      save_checkpoint();
    } catch (const Error& e) {
      spdlog::error("{}", e.what());
    }
  }

  bool over_time() const {
    return opts_.time_limit_s > 0.0 &&
           std::chrono::duration<double>(std::chrono::steady_clock::now() - started_).count() >= opts_.time_limit_s;
  }

  /// Whether a stop signal or the time limit ends the run before frame f (recorded in the summary).
  bool stopped_before(int f) {
    const int sig = g_stop_signal;
    if (!sig && !(f > first_frame_ && over_time())) return false;
    // Interrupted (Ctrl-C, scancel, a job's time limit): keep what was computed since the last
    // checkpoint, so that --resume loses nothing.
    if (writer_ && params_.output.checkpoint_every > 0 && f - 1 > summary_.last_checkpoint && f > first_frame_)
      try_save_checkpoint();
    if (sig) {
      summary_.status =
          (sig == SIGTERM ? "terminated after frame " : "interrupted after frame ") + std::to_string(f - 1);
      if (sig == SIGTERM) summary_.status += " (SIGTERM)";
    } else {
      summary_.status = "stopped at its time limit of " + format_duration(opts_.time_limit_s) + " after frame " +
                        std::to_string(f - 1);
      summary_.time_limited = true;
    }
    summary_.failed = true;
    summary_.stop_signal = sig;
    spdlog::warn("{}", summary_.status);
    return true;
  }

  /// Simulates, records and reports frame f; false when the run ends with it.
  bool step(int f, int total, const io::MemoryEstimate& run_limit) {
    FrameStats fs;
    try {
      fs = sim_.step_frame();
    } catch (const FrameInterrupted& e) {
      // A frame too long to finish after a stop signal: every frame on disk stays whole, and
      // --resume continues from the last checkpoint.
      const int sig = g_stop_signal;
      summary_.status = (sig == SIGTERM ? "terminated during frame " : "interrupted during frame ") +
                        std::to_string(f) + " (" + e.what() + ")";
      summary_.failed = true;
      summary_.stop_signal = sig;
      spdlog::warn("{}", summary_.status);
      return false;
    } catch (const Error& e) {
      // Non-finite positions, a broken guarantee, scripted motion beyond the bound: the frame
      // being computed is not written; every frame on disk stays whole and clean.
      summary_.status = std::string("failed: ") + e.what();
      summary_.failed = true;
      spdlog::error("{}", e.what());
      return false;
    }
    summary_.frames.push_back(fs);
    if (fs.violations_remaining > 0 || fs.penetrations > 0) ++summary_.violated_frames;
    if (writer_) {
      try {
        writer_->record(fs);
        if (params_.output.checkpoint_every > 0 && f % params_.output.checkpoint_every == 0 && f < total)
          save_checkpoint();
      } catch (const Error& e) {
        output_failed(e);
        return false;
      }
    }
    // The loader's estimate can err low (a sheet twisting into a rope): past the limit the machine
    // would swap or kill the run, so stop now, with every frame so far whole and a checkpoint.
    if (const double held = resident_bytes(); run_limit.limit_bytes > 0 && held > run_limit.limit_bytes) {
      const std::string why = memory_stop_message(f, held, run_limit);
      summary_.status = "failed: " + why;
      summary_.failed = true;
      spdlog::error("{}", why);
      if (writer_ && params_.output.checkpoint_every > 0 && f > summary_.last_checkpoint && f < total)
        try_save_checkpoint();
      return false;
    }
    report_progress(f, fs);
    return true;
  }

  void report_progress(int f, const FrameStats& fs) {
    if (progress_ && progress_->on_terminal())
      progress_->update(f - first_frame_ + 1,
                        fmt::format("{:.3f} s/frame  viol {}/{}  halted {}", fs.wall_s, fs.violations_detected,
                                    fs.violations_remaining, fs.halted_vertices));
    else if (progress_)
      progress_->update(
          f - first_frame_ + 1,
          fmt::format("{:.3f} s (xpbd {:.3f}, broad {:.3f}, narrow {:.3f}, resolution {:.3f}); violations {}/{}; "
                      "halted {}{}",
                      fs.wall_s, fs.times.xpbd, fs.times.broad, fs.times.narrow, fs.times.resolution,
                      fs.violations_detected, fs.violations_remaining, fs.halted_vertices,
                      fs.penetrations >= 0 ? "; penetrations " + std::to_string(fs.penetrations) : std::string()));
  }

  const RunOptions& opts_;
  const SimulationParams& params_;
  const RunIdentity& id_;
  Simulation& sim_;
  const exact::PenetrationAudit* audit_;
  const bool resumed_;
  const int first_frame_;
  RunSummary& summary_;
  std::unique_ptr<io::RunRecorder> writer_;
  std::optional<ProgressReporter> progress_;
  std::chrono::steady_clock::time_point started_;
};
}  // namespace

RunSummary run_scene(const RunOptions& opts) {
  // One writer per run directory, from before the checkpoint is read to the last byte written.
  io::DirLock lock;
  if (!opts.resume.empty() || !opts.out.empty())
    lock = io::DirLock::acquire(opts.resume.empty() ? opts.out : opts.resume, opts.command_line);
  std::optional<Resume> resume;
  if (!opts.resume.empty()) resume = load_resume(opts.resume);
  const std::vector<std::string> overrides = run_overrides(opts, resume);
  set_thread_count(opts.threads);

  const std::filesystem::path config = resume ? resume->ckpt.scene_file : opts.config;
  io::LoadedScene loaded = load_run_scene(config, overrides, resume);
  const std::uint64_t fingerprint = io::scene_fingerprint(loaded.scene.topo, loaded.scene.state);
  if (opts.advise && !resume)
    for (const std::string& advice : scene_advice(loaded.scene)) spdlog::warn("{}", advice);
  if (opts.advise && !resume)
    for (const std::string& clash : scripted_contacts(loaded.scene)) spdlog::warn("{}", clash);
  const SimulationParams params = loaded.scene.params;
  RunSummary summary = start_summary(opts, params, loaded.scene.topo.num_vertices(), resume.has_value());
  if (resume && !frames_left_to_resume(opts, *resume, params, summary)) return summary;

  // A component's own check of the scene (e.g. contact.dat.query_radius) names file, key and line.
  Simulation sim = [&] {
    try {
      return Simulation(std::move(loaded.scene));
    } catch (const Error& e) {
      io::rethrow_located(loaded, e);
    }
  }();
  std::shared_ptr<exact::PenetrationAudit> audit;
  if (params.debug.audit != AuditMode::off)
    sim.set_audit(io::make_audit_hook(sim.topology(), sim.positions(), params, &audit));
  cancel_on_stop_signals(sim);
  const int first_frame = resume ? restore_from(*resume, opts, sim, audit.get(), summary) : 1;
  SignalScope signals;
  const RunIdentity id{loaded, config, overrides, fingerprint};
  FrameLoop(opts, params, id, sim, audit.get(), resume.has_value(), first_frame, summary).run();
  return summary;
}

}  // namespace ccfr::app
