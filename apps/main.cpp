// The ccfr command line: run, audit, ablate, bench, render.
#include <CLI/CLI.hpp>

#include <cmath>
#include <cstdio>
#include <memory>
#include <string>

#include "ccfr/core/error.hpp"
#include "ccfr/core/log.hpp"
#include "ccfr/core/parallel.hpp"
#include "commands.hpp"
#include "exit_codes.hpp"
#include "progress.hpp"
#include "run_driver.hpp"

namespace {

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
        if (!CLI::detail::lexical_cast(in, x) || !(strict ? x > 0 : x >= 0) || !std::isfinite(x))
          return "Value " + in + " out of range: must be a finite number " + (strict ? "> 0" : ">= 0");
        return std::string();
      });
    }
    if (opt->check_lname("threads"))
      opt->check(CLI::Validator(
          [](std::string& in) {
            long long v = 0;
            if (!CLI::detail::lexical_cast(in, v)) return std::string();  // CLI11's own check names it
            const std::string problem = ccfr::thread_count_problem(v);
            return problem.empty() ? problem : "Value " + in + " " + problem;
          },
          "", "max threads"));
  }
  for (CLI::App* sub : app.get_subcommands({})) readable_checks(*sub);
}

/// Options whose value names something: given as "" they would silently mean their default
/// (`--solver ""` the scene's solver, `ablate --solvers ""` all six). CLI11 skips validators on
/// empty values, so this checks after each subcommand's parse.
void refuse_empty_values(CLI::App& app) {
  app.parse_complete_callback([&app] {
    for (const char* name : {"--solver", "--solvers"}) {
      const CLI::Option* opt = app.get_option_no_throw(name);
      if (!opt) continue;
      for (const std::string& value : opt->results())
        if (value.empty())
          throw CLI::ValidationError(name, "is empty: name a contact solver (`ccfr schema` lists them)");
    }
  });
  for (CLI::App* sub : app.get_subcommands({})) refuse_empty_values(*sub);
}

/// The global options -q and --log-level. They take effect while parsing, so a subcommand's own
/// default level (warn for audit, bench, render) gives way to them.
void add_global_options(CLI::App& app, const std::shared_ptr<bool>& explicit_level) {
  app.add_option_function<std::string>(
         "--log-level",
         [explicit_level](const std::string& level) {
           *explicit_level = true;
           ccfr::set_log_level_override(level);
         },
         "Log level on stderr: trace, debug, info, warn, error or off (default: warn for audit, bench, render, "
         "plot and sweep collect; info for the others)")
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
}

/// Global options go before or after any subcommand. A subcommand passes options it does not
/// know to ccfr (fallthrough); a nested one (`ccfr sweep status DIR -q`) takes them itself, since
/// falling through to `sweep` would also accept sweep's own options and positional there.
void global_options_everywhere(CLI::App& app, const std::shared_ptr<bool>& explicit_level) {
  for (CLI::App* sub : app.get_subcommands({})) {
    sub->fallthrough();
    for (CLI::App* nested : sub->get_subcommands({})) {
      add_global_options(*nested, explicit_level);
      global_options_everywhere(*nested, explicit_level);
    }
  }
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"ccfr: penetration-free XPBD simulation with Convex Collision-Free Regions"};
  app.require_subcommand(1);
  app.set_version_flag("--version", std::string(ccfr::app::version_string()));
  ccfr::init_logging("info");  // logs to stderr from the start, whatever a subcommand logs first
  auto explicit_level = std::make_shared<bool>(false);
  add_global_options(app, explicit_level);
  ccfr::app::register_commands(app);
  global_options_everywhere(app, explicit_level);
  // Every command's --help names the global options (a subcommand's own list omits what it lets
  // fall through to ccfr) and the exit codes, from the one table of exit_codes.hpp.
  app.footer(ccfr::app::exit_code_text());
  const std::string footer =
      "Global options (before or after the command): --log-level LEVEL (trace, debug, info, "
      "warn, error, off), -q/--quiet, -h/--help (ccfr --help)\n" +
      ccfr::app::exit_code_text();
  for (CLI::App* sub : app.get_subcommands({})) {
    sub->footer(footer);
    for (CLI::App* nested : sub->get_subcommands({})) nested->footer(footer);
  }
  for (CLI::App* sub : app.get_subcommands({})) refuse_empty_values(*sub);
  ccfr::app::set_invocation(argc, argv);  // run.json records the command line as typed
  readable_checks(app);
  // CLI11 says only "A subcommand is required" for `ccfr frobnicate`: name the word and the commands.
  if (argc > 1 && argv[1][0] != '-') {
    bool known = false;
    std::string names;
    for (const CLI::App* sub : app.get_subcommands({})) {
      known = known || sub->check_name(argv[1]);
      if (!sub->get_group().empty())  // hidden ones (help-markdown) are not offered
        names += (names.empty() ? "" : ", ") + sub->get_name();
    }
    if (!known) {
      std::fprintf(stderr, "unknown command '%s'; the commands are %s (ccfr --help)\n", argv[1], names.c_str());
      return 2;
    }
  }
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    // app.exit prints the message (or the help); every command-line error then exits 2, the
    // documented code for a user's mistake, not CLI11's own codes (104-109).
    return app.exit(e) == 0 ? 0 : 2;
  }
  return ccfr::app::exit_code();
}
