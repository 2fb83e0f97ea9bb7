// `ccfr export DIR --format vtu,pc2,...`: writes a finished (or cut short) run's OBJ frames in
// other formats (docs/interop.md), into DIR or --out.
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <sstream>
#include <string>
#include <vector>

#include "ccfr/io/export_run.hpp"
#include "ccfr/io/formats.hpp"
#include "commands.hpp"
#include "plot_script.hpp"
#include "progress.hpp"
#include "run_driver.hpp"

namespace ccfr::app {

namespace {
struct ExportOptions {
  std::filesystem::path dir, out;
  std::vector<std::string> formats;
};
// The program that shows what was exported (docs/interop.md): the first format with a viewer.
std::string viewer_command(const std::vector<std::string>& formats, const std::filesystem::path& run,
                           const std::filesystem::path& out) {
  for (const std::string& f : formats) {
    if (f == "vtu") return "paraview " + shell_quote((out / "vtk" / "frames.pvd").string());
    if (f == "pc2") {
      const auto script = find_script("import_blender.py");
      return "blender --python " + shell_quote(script ? script->string() : "scripts/import_blender.py") + " -- " +
             shell_quote(out.string());
    }
    if (f == "usda") return "usdview " + shell_quote((out / "usd" / "scene.usda").string());
  }
  return "ccfr render " + shell_quote(run.string());
}
}  // namespace

void register_export(CLI::App& app) {
  auto opts = std::make_shared<ExportOptions>();
  std::string names;
  for (const auto& n : io::frame_writer_names()) names += (names.empty() ? "" : ", ") + n;
  auto* cmd = app.add_subcommand("export", "Write a run's frames in other formats (" + names + ")");
  cmd->add_option("dir", opts->dir, "Run directory (with run.json and frames/frame_*.obj)")->required();
  cmd->add_option("--format,-f", opts->formats, "Formats, comma-separated or repeated: " + names)
      ->required()
      ->delimiter(',');
  cmd->add_option("--out", opts->out, "Write into this directory instead of the run directory");
  cmd->callback([opts] {
    guarded([&] {
      const auto t0 = std::chrono::steady_clock::now();
      const auto formats = io::parse_output_formats(opts->formats);
      const int n = io::export_run(opts->dir, formats, opts->out, invocation_string());
      std::string list;
      for (const auto& f : opts->formats) list += (list.empty() ? "" : ",") + f;
      const std::filesystem::path out = opts->out.empty() ? opts->dir : opts->out;
      const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      std::printf("exported %d frames of %s as %s into %s in %s; next: %s\n", n, opts->dir.string().c_str(),
                  list.c_str(), out.string().c_str(), format_duration(secs).c_str(),
                  viewer_command(formats, opts->dir, out).c_str());
      return 0;
    });
  });
}

}  // namespace ccfr::app
