#pragma once
// The Python plotting scripts shipped with ccfr (plot_stats.py, plot_ablation.py), found without
// a source tree and started without a shell: used by `ccfr plot` and the multi-run commands.
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace ccfr::app {

/// `name` in, first found: $CCFR_SCRIPTS_DIR; <prefix>/share/ccfr/scripts where the executable is
/// <prefix>/bin/ccfr (an installed ccfr); the source tree's scripts/ (a build tree).
std::optional<std::filesystem::path> find_script(const std::string& name);

/// Runs `python3 SCRIPT args...` without a shell (the first python3 with matplotlib: $CCFR_PYTHON
/// when set, else on PATH, else /usr/bin/python3); output discarded unless `show_output`.
/// Returns true when the script exited with 0; otherwise false with `message` saying what was
/// missing (the script, python3, matplotlib) or how the script failed.
bool run_plot_script(const std::string& name, const std::vector<std::string>& args, std::string& message,
                     bool show_output = false);

}  // namespace ccfr::app
