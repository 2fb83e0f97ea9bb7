// `ccfr bench CONFIG`: runs a scene without writing anything and prints per-stage medians, for
// profiling and for docs/performance.md.
#include <cmath>
#include <cstdio>

#include "ccfr/core/error.hpp"
#include "ccfr/core/log.hpp"
#include "ccfr/core/parallel.hpp"
#include "ccfr/io/scene_loader.hpp"
#include "commands.hpp"
#include "frame_summary.hpp"
#include "progress.hpp"
#include "run_driver.hpp"

namespace ccfr::app {

namespace {
struct BenchOptions {
  RunOptions run;
  int warmup = 0;
};

// Counts print as integers; a median of an even number of frames may end in .5.
std::string count_text(double v) {
  char b[32];
  std::snprintf(b, sizeof b, v == std::floor(v) ? "%.0f" : "%.1f", v);
  return b;
}

int run_bench(const BenchOptions& o) {
  // The frames come from --frames or the scene; the scene is loaded first so that a warm-up
  // that would leave nothing to measure is refused before minutes of simulation.
  int frames_total = o.run.frames;
  if (frames_total < 0) {
    std::vector<std::string> overrides = o.run.overrides;
    if (!o.run.solver.empty()) overrides.push_back("contact.solver=" + o.run.solver);
    frames_total = io::load_scene(o.run.config, overrides).scene.params.time.frames;
  }
  const std::string frames_from =
      o.run.frames >= 0 ? std::string("--frames") : "time.frames of " + o.run.config.string();
  if (frames_total == 0)
    throw Error("bench needs at least one frame to measure, but " + frames_from + " is 0: give --frames N");
  if (o.warmup >= frames_total)
    throw Error("--warmup " + std::to_string(o.warmup) + " leaves no frame to measure: it must be smaller than the " +
                std::to_string(frames_total) + " frames simulated (" + frames_from + ")");
  RunOptions ro = o.run;
  ro.out.clear();
  ro.progress_label = "bench frame";
  const RunSummary s = run_scene(ro);
  std::vector<FrameStats> frames(s.frames.begin() + std::min<size_t>(o.warmup, s.frames.size()), s.frames.end());
  std::printf(
      "bench %s: solver %s, %d vertices, %d substeps x %d iterations, %d threads, %zu frames (%d warm-up skipped)\n",
      o.run.config.string().c_str(), s.solver.c_str(), s.vertices, s.substeps, s.iterations, thread_count(),
      frames.size(), o.warmup);
  std::printf("%-20s %12s %12s %12s\n", "stage (s/frame)", "median", "mean", "max");
  auto line = [&](const char* name, const std::function<double(const FrameStats&)>& get) {
    const Aggregate a = aggregate(frames, get);
    std::printf("%-20s %12.6f %12.6f %12.6f\n", name, a.median, a.mean, a.max);
  };
  line("frame", [](const FrameStats& f) { return f.wall_s; });
  line("cpu, all threads", [](const FrameStats& f) { return f.cpu_s; });
  line("xpbd", [](const FrameStats& f) { return f.times.xpbd; });
  line("broad phase", [](const FrameStats& f) { return f.times.broad; });
  line("narrow phase", [](const FrameStats& f) { return f.times.narrow; });
  line("resolution", [](const FrameStats& f) { return f.times.resolution; });
  // Amdahl: the time outside parallel loops, per stage and for the frame, and what it allows.
  std::printf("%-20s %12s %12s %12s\n", "serial part (s/frame)", "median", "mean", "share");
  const double wall_sum = aggregate(frames, [](const FrameStats& f) { return f.wall_s; }).mean;
  auto serial = [&](const char* name, const std::function<double(const FrameStats&)>& get) {
    const Aggregate a = aggregate(frames, get);
    std::printf("%-20s %12.6f %12.6f %11.1f%%\n", name, a.median, a.mean,
                wall_sum > 0.0 ? 100.0 * a.mean / wall_sum : 0.0);
    return a.mean;
  };
  const double s_frame = serial("frame", [](const FrameStats& f) { return f.serial_s; });
  serial("xpbd", [](const FrameStats& f) { return f.times.xpbd_serial; });
  serial("broad phase", [](const FrameStats& f) { return f.times.broad_serial; });
  serial("narrow phase", [](const FrameStats& f) { return f.times.narrow_serial; });
  serial("resolution", [](const FrameStats& f) { return f.times.resolution_serial; });
  serial("check", [](const FrameStats& f) { return f.times.check_serial; });
  if (wall_sum > 0.0) {
    // At p threads the parallel part shrinks at best p-fold: T(p) >= serial + (T - serial) / p.
    const double sf = s_frame / wall_sum;
    const int p = thread_count();
    auto speedup = [&](int q) { return 1.0 / (sf + (1.0 - sf) * p / q); };
    std::printf(
        "amdahl: serial fraction %.3f at %d thread%s; at most %.2fx from 1 to 2 threads, %.2fx to 8, %.2fx to "
        "16 (from this run's parallel time times %d)\n",
        sf, p, p == 1 ? "" : "s", speedup(2) / speedup(1), speedup(8) / speedup(1), speedup(16) / speedup(1), p);
  }
  std::printf("%-20s %12s %12s %12s\n", "count (per frame)", "median", "mean", "max");
  auto count = [&](const char* name, const std::function<double(const FrameStats&)>& get) {
    const Aggregate a = aggregate(frames, get);
    std::printf("%-20s %12s %12.1f %12s\n", name, count_text(a.median).c_str(), a.mean, count_text(a.max).c_str());
  };
  count("candidates", [](const FrameStats& f) { return f.candidates; });
  count("constraints", [](const FrameStats& f) { return f.constraints; });
  count("violations", [](const FrameStats& f) { return f.violations_detected; });
  count("remaining", [](const FrameStats& f) { return f.violations_remaining; });
  count("halted", [](const FrameStats& f) { return f.halted_vertices; });
  count("outer iterations", [](const FrameStats& f) { return f.outer_iterations; });
  std::printf("status: %s; %zu frames in %s; next: ccfr run %s --out out/%s\n", s.status.c_str(), s.frames.size(),
              format_duration(s.wall_s).c_str(), shell_quote(o.run.config.string()).c_str(),
              shell_quote(o.run.config.stem().string()).c_str());
  return s.failed ? 1 : 0;
}
}  // namespace

void register_bench(CLI::App& app) {
  auto o = std::make_shared<BenchOptions>();
  auto* cmd = app.add_subcommand("bench", "Run a scene without output and print per-stage medians (profiling)");
  cmd->add_option("config", o->run.config, "Scene file (YAML)")->required();
  cmd->add_option("--warmup", o->warmup, "Frames excluded from the statistics (fewer than the frames simulated)")
      ->check(CLI::NonNegativeNumber);
  add_run_options(cmd, o->run);
  cmd->callback([o] {
    init_logging("warn");
    guarded([o] { return run_bench(*o); });
  });
}

}  // namespace ccfr::app
