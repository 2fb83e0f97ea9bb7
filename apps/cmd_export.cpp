// `ccfr export DIR --format vtu,pc2,...`: writes a finished (or cut short) run's OBJ frames in
// other formats (docs/interop.md), into DIR or --out.
#include <cstdio>
#include <filesystem>
#include <sstream>
#include <string>
#include <vector>

#include "ccfr/io/formats.hpp"
#include "commands.hpp"

namespace ccfr::app {

namespace {
struct ExportOptions {
  std::filesystem::path dir, out;
  std::vector<std::string> formats;
};
}  // namespace

void register_export(CLI::App& app) {
  auto opts = std::make_shared<ExportOptions>();
  std::string names;
  for (const auto& n : io::output_format_names()) names += (names.empty() ? "" : ", ") + n;
  auto* cmd = app.add_subcommand("export", "Write a run's frames in other formats (" + names + ")");
  cmd->add_option("dir", opts->dir, "Run directory (with run.json and frames/frame_*.obj)")->required();
  cmd->add_option("--format,-f", opts->formats, "Formats, comma-separated or repeated: " + names)
      ->required()
      ->delimiter(',');
  cmd->add_option("--out", opts->out, "Write into this directory instead of the run directory");
  cmd->callback([opts] {
    guarded([&] {
      const auto formats = io::parse_output_formats(opts->formats);
      const int n = io::export_run(opts->dir, formats, opts->out);
      std::string list;
      for (const auto& f : opts->formats) list += (list.empty() ? "" : ",") + f;
      std::printf("exported %d frames of %s as %s into %s\n", n, opts->dir.string().c_str(), list.c_str(),
                  (opts->out.empty() ? opts->dir : opts->out).string().c_str());
      return 0;
    });
  });
}

}  // namespace ccfr::app
