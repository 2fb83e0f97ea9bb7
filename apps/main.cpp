// The ccfr command line: run, audit, ablate, bench, render.
#include <CLI/CLI.hpp>

#include <cstdio>

#include "ccfr/core/error.hpp"
#include "ccfr/core/log.hpp"
#include "commands.hpp"

int main(int argc, char** argv) {
  CLI::App app{"ccfr: penetration-free XPBD simulation with Convex Collision-Free Regions"};
  app.require_subcommand(1);
  app.set_version_flag("--version", std::string(ccfr::app::version_string()));
  ccfr::app::register_commands(app);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }
  return ccfr::app::exit_code();
}
