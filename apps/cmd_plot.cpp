// `ccfr plot DIR`: draws a run's stats.csv (stats.png) or an ablation's ablation.csv
// (ablation.png) with the plotting scripts shipped with ccfr. Exit codes: 0 drawn, 2 bad input
// or no Python/matplotlib.
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>

#include "ccfr/core/error.hpp"
#include "ccfr/core/log.hpp"
#include "commands.hpp"
#include "plot_script.hpp"

namespace ccfr::app {

namespace {
namespace fs = std::filesystem;

struct PlotOptions {
  fs::path dir;
  fs::path out;
  std::string title;
};

int run_plot(const PlotOptions& o) {
  if (!fs::is_directory(o.dir)) throw Error("'" + o.dir.string() + "' is not a directory");
  const bool ablation = fs::is_regular_file(o.dir / "ablation.csv");
  if (!ablation && !fs::is_regular_file(o.dir / "stats.csv"))
    throw Error("'" + o.dir.string() + "' holds neither stats.csv (a run) nor ablation.csv (an ablation)");
  const fs::path png = o.out.empty() ? o.dir / (ablation ? "ablation.png" : "stats.png") : o.out;
  std::vector<std::string> args{o.dir.string(), "--out", png.string()};
  if (!o.title.empty()) args.insert(args.end(), {"--title", o.title});
  std::string message;
  if (!run_plot_script(ablation ? "plot_ablation.py" : "plot_stats.py", args, message, true))
    throw Error("no plot drawn: " + message);
  std::printf("plot: %s\n", png.string().c_str());
  return 0;
}
}  // namespace

void register_plot(CLI::App& app) {
  auto o = std::make_shared<PlotOptions>();
  auto* cmd = app.add_subcommand(
      "plot",
      "Draw a run's stats.csv as stats.png, or an ablation's ablation.csv as ablation.png (python3-matplotlib)");
  cmd->add_option("dir", o->dir, "Run directory (stats.csv) or ablation directory (ablation.csv)")->required();
  cmd->add_option("--out", o->out, "PNG to write (default: DIR/stats.png or DIR/ablation.png)");
  cmd->add_option("--title", o->title, "Title (default: the scene name from run.json)");
  cmd->callback([o] {
    init_logging("warn");
    guarded([o] { return run_plot(*o); });
  });
}

}  // namespace ccfr::app
