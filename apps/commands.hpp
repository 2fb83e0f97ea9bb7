#pragma once
// Subcommands of the ccfr executable: one file per subcommand (cmd_<name>.cpp), registered in
// commands.cpp. A subcommand's callback sets the process exit code through set_exit_code().
#include <CLI/CLI.hpp>

#include <functional>
#include <string_view>

namespace ccfr::app {

std::string_view version_string();
void register_commands(CLI::App& app);
int exit_code();
void set_exit_code(int code);
/// Runs `body`, turning ccfr::Error (user error) into a one-line message and exit code
/// `user_error_code`, and other exceptions into "internal error" with exit code 3.
void guarded(const std::function<int()>& body, int user_error_code = 2);

void register_run(CLI::App& app);
void register_audit(CLI::App& app);
void register_ablate(CLI::App& app);
void register_sweep(CLI::App& app);
void register_bench(CLI::App& app);
void register_render(CLI::App& app);
void register_schema(CLI::App& app);
void register_export(CLI::App& app);
void register_plot(CLI::App& app);
void register_help_markdown(CLI::App& app);

}  // namespace ccfr::app
