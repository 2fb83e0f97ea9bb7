#pragma once
/// @file process.hpp
/// Starting external programs (ffmpeg for `ccfr render`, tetgen for surface meshes) without a shell.
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

}  // namespace ccfr
