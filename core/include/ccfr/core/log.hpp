#pragma once
/// @file log.hpp
/// Logging through spdlog's default logger ("ccfr" pattern, stderr: stdout carries results only).
#include <spdlog/spdlog.h>

#include <string_view>

namespace ccfr {

/// Configures the default logger: level name (trace, debug, info, warn, error, off). A level
/// fixed by set_log_level_override() wins over `level`, the caller's default.
void init_logging(std::string_view level = "info");

/// Fixes the level for every later init_logging() call (the command line's --log-level or
/// --quiet, which apply whatever default a subcommand asks for); empty clears it.
void set_log_level_override(std::string_view level);

}  // namespace ccfr
