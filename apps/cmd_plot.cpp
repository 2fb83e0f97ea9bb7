// `ccfr plot DIR`: draws a run's stats.csv (stats.png) or an ablation's ablation.csv
// (ablation.png) with the plotting scripts shipped with ccfr. Exit codes: 0 drawn, 2 bad input
// or no Python/matplotlib.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "ccfr/core/error.hpp"
#include "ccfr/core/log.hpp"
#include "ccfr/io/user_file.hpp"
#include "commands.hpp"
#include "plot_script.hpp"
#include "progress.hpp"
#include "run_driver.hpp"

namespace ccfr::app {

namespace {
namespace fs = std::filesystem;

struct PlotOptions {
  fs::path dir;
  fs::path out;
  std::string title;
};

/// A stats.csv as ccfr writes it: a header with a `frame` column, then rows of as many numeric (or
/// empty) cells; only the last row may be cut short, by a run killed mid-write. Anything else
/// is not a ccfr stats.csv, and plotting it would draw empty panels and exit 0.
void check_stats_csv(const fs::path& csv) {
  const std::string text = io::read_user_file(csv, "stats file", std::uintmax_t{1} << 30);
  const std::string label = io::printable(csv.string());
  std::vector<std::string> header;
  size_t line_no = 0;
  for (size_t at = 0; at < text.size();) {
    const size_t nl = text.find('\n', at);
    const bool last_cut = nl == std::string::npos;  // no newline: a row cut short
    std::string line = text.substr(at, last_cut ? std::string::npos : nl - at);
    at = last_cut ? text.size() : nl + 1;
    ++line_no;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    std::vector<std::string> cells;
    std::stringstream ss(line);
    for (std::string c; std::getline(ss, c, ',');) cells.push_back(c);
    if (!line.empty() && line.back() == ',') cells.emplace_back();
    if (line_no == 1) {
      header = cells;
      if (std::find(header.begin(), header.end(), "frame") == header.end())
        throw Error(label + ":1: not a ccfr stats.csv: the header has no `frame` column (got '" +
                    io::printable(line.substr(0, 80)) + "')");
      continue;
    }
    if (line.empty() && !last_cut) continue;
    if (cells.size() > header.size() || (!last_cut && cells.size() != header.size()))
      throw Error(label + ":" + std::to_string(line_no) + ": " + std::to_string(cells.size()) +
                  " fields, the header has " + std::to_string(header.size()));
    for (size_t k = 0; k < cells.size(); ++k) {
      const std::string& c = cells[k];
      if (c.empty()) continue;
      char* end = nullptr;
      std::strtod(c.c_str(), &end);
      if (*end != '\0' && !(last_cut && k + 1 == cells.size()))
        throw Error(label + ":" + std::to_string(line_no) + ": column '" + io::printable(header[k]) + "': '" +
                    io::printable(c.substr(0, 40)) + "' is not a number");
    }
  }
  if (header.empty()) throw Error(label + " is empty: not a ccfr stats.csv");
}

/// The first solver's run of an ablation (the first column of ablation.csv's first row).
std::string first_ablation_run(const fs::path& csv) {
  std::ifstream in(csv);
  std::string line;
  std::getline(in, line);  // the header
  std::getline(in, line);
  return line.substr(0, line.find(','));
}

int run_plot(const PlotOptions& o) {
  if (!fs::is_directory(o.dir)) throw Error("'" + o.dir.string() + "' is not a directory");
  const auto t0 = std::chrono::steady_clock::now();
  const bool ablation = fs::is_regular_file(o.dir / "ablation.csv");
  if (!ablation && !fs::is_regular_file(o.dir / "stats.csv"))
    throw Error("'" + o.dir.string() + "' holds neither stats.csv (a run) nor ablation.csv (an ablation)");
  if (!ablation) check_stats_csv(o.dir / "stats.csv");
  const char* name = ablation ? "ablation.png" : "stats.png";
  fs::path png = o.out.empty() ? o.dir / name : o.out;
  // A folder (existing, or named with a trailing /) gets the default name inside it, not DIR.png beside it.
  std::error_code ec;
  if (!o.out.empty() && (fs::is_directory(o.out, ec) || !o.out.has_filename())) png = o.out / name;
  // matplotlib adds .png to a name without an extension: print (and pass) the file it writes.
  if (png.extension().empty()) png += ".png";
  std::vector<std::string> args{o.dir.string(), "--out", png.string()};
  if (!o.title.empty()) args.insert(args.end(), {"--title", o.title});
  std::string message;
  if (!run_plot_script(ablation ? "plot_ablation.py" : "plot_stats.py", args, message, true))
    throw Error("no plot drawn: " + message);
  const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  // An ablation's next look is its runs' frames; a run's, its pictures.
  std::printf("plot: %s in %s; next: ccfr render %s\n", png.string().c_str(), format_duration(secs).c_str(),
              shell_quote((ablation ? o.dir / first_ablation_run(o.dir / "ablation.csv") : o.dir).string()).c_str());
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
