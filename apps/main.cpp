// The ccfr command line: run, audit, ablate, bench, render.
#include <CLI/CLI.hpp>

#include <cstdio>
#include <memory>
#include <string>

#include "ccfr/core/error.hpp"
#include "ccfr/core/log.hpp"
#include "commands.hpp"
#include "progress.hpp"
#include "run_driver.hpp"

namespace {

/// Most worker threads accepted by --threads: far beyond any machine ccfr runs on, yet small
/// enough that per-thread state stays a few megabytes (2147483647 tried to allocate gigabytes).
constexpr long kMaxThreads = 1024;

/// CLI11's NonNegativeNumber / PositiveNumber print their bound, DBL_MAX, as a 309-digit number in
/// errors; replace their checks with readable ones, and bound every --threads option.
void readable_checks(CLI::App& app) {
  for (CLI::Option* opt : app.get_options()) {
    // The validators carry their bound only in their description (NONNEGATIVE, POSITIVE).
    for (int i = 0;; ++i) {
      CLI::Validator* v = nullptr;
      try {
        v = opt->get_validator(i);
      } catch (const CLI::OptionNotFound&) {
        break;
      }
      const std::string desc = v->get_description();
      if (desc != "NONNEGATIVE" && desc != "POSITIVE") continue;
      const bool strict = desc == "POSITIVE";
      v->operation([strict](std::string& in) {
        double x = 0;
        if (!CLI::detail::lexical_cast(in, x) || !(strict ? x > 0 : x >= 0))
          return "Value " + in + " out of range: must be a number " + (strict ? "> 0" : ">= 0");
        return std::string();
      });
    }
    if (opt->check_lname("threads"))
      opt->check(CLI::Validator(
          [](std::string& in) {
            long v = 0;
            if (CLI::detail::lexical_cast(in, v) && v > kMaxThreads)
              return "Value " + in + " is too many worker threads: at most " + std::to_string(kMaxThreads) +
                     " (0 uses all cores)";
            return std::string();
          },
          "", "max threads"));
  }
  for (CLI::App* sub : app.get_subcommands({})) readable_checks(*sub);
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"ccfr: penetration-free XPBD simulation with Convex Collision-Free Regions"};
  app.require_subcommand(1);
  app.set_version_flag("--version", std::string(ccfr::app::version_string()));
  ccfr::init_logging("info");  // logs to stderr from the start, whatever a subcommand logs first
  // Global options, accepted before or after the subcommand (fallthrough); they take effect while
  // parsing, so a subcommand's own default level (warn for audit, bench, render) gives way to them.
  auto explicit_level = std::make_shared<bool>(false);
  app.add_option_function<std::string>(
         "--log-level",
         [explicit_level](const std::string& level) {
           *explicit_level = true;
           ccfr::set_log_level_override(level);
         },
         "Log level on stderr: trace, debug, info, warn, error or off (default: info for run and ablate, warn "
         "for the others)")
      ->check(CLI::IsMember({"trace", "debug", "info", "warn", "error", "off"}))
      ->trigger_on_parse();
  app.add_flag_callback(
         "-q,--quiet",
         [explicit_level] {
           ccfr::app::set_quiet(true);
           if (!*explicit_level) ccfr::set_log_level_override("warn");
         },
         "No progress and no info logs (warnings and errors still on stderr); results still on stdout")
      ->trigger_on_parse();
  ccfr::app::register_commands(app);
  for (CLI::App* sub : app.get_subcommands({})) sub->fallthrough();
  ccfr::app::set_invocation(argc, argv);  // run.json records the command line as typed
  readable_checks(app);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }
  return ccfr::app::exit_code();
}
