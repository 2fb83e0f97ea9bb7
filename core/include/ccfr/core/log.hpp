#pragma once
/// @file log.hpp
/// Logging through spdlog's default logger ("ccfr" pattern, stderr).
#include <spdlog/spdlog.h>

#include <string_view>

namespace ccfr {

/// Configures the default logger once: level name (trace, debug, info, warn, error, off).
void init_logging(std::string_view level = "info");

}  // namespace ccfr
