#include "commands.hpp"

#include <cstdio>
#include <exception>
#include <filesystem>

#include "ccfr/core/error.hpp"
#include "ccfr/io/output.hpp"
#include "ccfr/io/user_file.hpp"
#include "exit_codes.hpp"

namespace ccfr::app {

namespace {
int g_exit_code = 0;
}

std::string_view version_string() {
  static const std::string v = io::version() + " (" + io::git_commit() + ")";
  return v;
}

int exit_code() { return g_exit_code; }
void set_exit_code(int code) { g_exit_code = code; }

void guarded(const std::function<int()>& body, int user_error_code) {
  try {
    set_exit_code(body());
  } catch (const Error& e) {
    // Messages quote file content and names: no byte of it may drive the terminal.
    std::fprintf(stderr, "error: %s\n", io::printable(e.what(), true).c_str());
    set_exit_code(user_error_code);
  } catch (const std::filesystem::filesystem_error& e) {
    // A path the user gave that cannot be looked at (a symlink loop, a name longer than the file
    // system allows, a directory without permission): theirs to fix, not ccfr's bug.
    const std::string where = e.path1().empty() ? std::string() : " '" + io::printable(e.path1().string()) + "'";
    std::fprintf(stderr, "error: cannot access%s: %s\n", where.c_str(), e.code().message().c_str());
    set_exit_code(user_error_code);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "internal error: %s\n", e.what());
    set_exit_code(kExitInternalError);
  }
}

// The subcommand table: one line per subcommand, each defined in its own cmd_<name>.cpp.
void register_commands(CLI::App& app) {
  register_run(app);
  register_audit(app);
  register_ablate(app);
  register_sweep(app);
  register_bench(app);
  register_render(app);
  register_plot(app);
  register_schema(app);
  register_export(app);
  register_help_markdown(app);  // hidden: generates docs/cli.md from the definitions above
}

}  // namespace ccfr::app
