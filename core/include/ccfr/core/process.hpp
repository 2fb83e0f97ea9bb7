#pragma once
/// @file process.hpp
/// Starting external programs (ffmpeg for `ccfr render`, tetgen for surface meshes) without a shell,
/// and what this process holds in memory.
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace ccfr {

/// The executable `name` on PATH, if any.
std::optional<std::filesystem::path> find_program(std::string_view name);

/// Runs `args[0]` (looked up on PATH) with `args`, waits, and returns its exit code (-1 if it could
/// not start or did not exit normally). With `output`, its stdout and stderr go to that file.
int run_process(const std::vector<std::string>& args, const std::filesystem::path& output = {});

/// This process's resident memory in bytes (VmRSS of /proc/self/status); 0 when unknown.
double resident_bytes();
/// The most it has held so far (VmHWM, the high-water mark); 0 when unknown.
double peak_resident_bytes();

}  // namespace ccfr
