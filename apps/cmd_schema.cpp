// `ccfr schema`: the reference of every scene key, generated from the schema the parser uses.
#include <cstdio>

#include "ccfr/io/scene_loader.hpp"
#include "commands.hpp"

namespace ccfr::app {

void register_schema(CLI::App& app) {
  auto* cmd =
      app.add_subcommand("schema",
                         "Print the reference of every scene-file key and every registered component (Markdown; the "
                         "source of docs/config.md)");
  cmd->callback([] {
    guarded([] {
      std::fputs(io::config_reference_markdown().c_str(), stdout);
      return 0;
    });
  });
}

}  // namespace ccfr::app
