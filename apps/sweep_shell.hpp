#pragma once
// The shell as the sweep backends use it: quoting an argument, running a command for its output,
// and the path of this executable (which the cells and the Slurm array tasks run again).
#include <filesystem>
#include <string>
#include <utility>

namespace ccfr::app {

/// `a` in single quotes, always (shell_quote of run_driver.hpp leaves plain words bare).
std::string single_quote(const std::string& a);
/// Output of a command run through the shell (sbatch, squeue, sacct), stderr included, and its exit
/// code (-1 when it did not exit normally or could not start).
std::pair<int, std::string> capture(const std::string& cmd);
/// This executable (/proc/self/exe).
std::filesystem::path self_exe();

}  // namespace ccfr::app
