// `ccfr bench CONFIG`: runs a scene without writing anything and prints per-stage medians, for
// profiling and for docs/performance.md.
#include <cstdio>

#include "ccfr/core/log.hpp"
#include "ccfr/core/parallel.hpp"
#include "commands.hpp"
#include "frame_summary.hpp"
#include "run_driver.hpp"

namespace ccfr::app {

namespace {
struct BenchOptions {
  RunOptions run;
  int warmup = 0;
};

int run_bench(const BenchOptions& o) {
  RunOptions ro = o.run;
  ro.out.clear();
  ro.progress = false;
  const RunSummary s = run_scene(ro);
  std::vector<FrameStats> frames(s.frames.begin() + std::min<size_t>(o.warmup, s.frames.size()), s.frames.end());
  std::printf("bench %s: solver %s, %d vertices, %d substeps x %d iterations, %d threads, %zu frames (%d warm-up skipped)\n",
              o.run.config.string().c_str(), s.solver.c_str(), s.vertices, s.substeps, s.iterations, thread_count(), frames.size(),
              o.warmup);
  std::printf("%-20s %12s %12s %12s\n", "stage (s/frame)", "median", "mean", "max");
  auto line = [&](const char* name, const std::function<double(const FrameStats&)>& get) {
    const Aggregate a = aggregate(frames, get);
    std::printf("%-20s %12.6f %12.6f %12.6f\n", name, a.median, a.mean, a.max);
  };
  line("frame", [](const FrameStats& f) { return f.wall_s; });
  line("xpbd", [](const FrameStats& f) { return f.times.xpbd; });
  line("broad phase", [](const FrameStats& f) { return f.times.broad; });
  line("narrow phase", [](const FrameStats& f) { return f.times.narrow; });
  line("resolution", [](const FrameStats& f) { return f.times.resolution; });
  line("candidates", [](const FrameStats& f) { return f.candidates; });
  line("constraints", [](const FrameStats& f) { return f.constraints; });
  line("violations", [](const FrameStats& f) { return f.violations_detected; });
  line("remaining", [](const FrameStats& f) { return f.violations_remaining; });
  line("halted", [](const FrameStats& f) { return f.halted_vertices; });
  line("outer iterations", [](const FrameStats& f) { return f.outer_iterations; });
  std::printf("status: %s\n", s.status.c_str());
  return s.failed ? 1 : 0;
}
}  // namespace

void register_bench(CLI::App& app) {
  auto o = std::make_shared<BenchOptions>();
  auto* cmd = app.add_subcommand("bench", "Run a scene without output and print per-stage medians (profiling)");
  cmd->add_option("config", o->run.config, "Scene file (YAML)")->required();
  cmd->add_option("--warmup", o->warmup, "Frames excluded from the statistics")->check(CLI::NonNegativeNumber);
  add_run_options(cmd, o->run);
  cmd->callback([o] {
    init_logging("warn");
    guarded([o] { return run_bench(*o); });
  });
}

}  // namespace ccfr::app
