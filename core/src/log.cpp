#include "ccfr/core/log.hpp"

#include <spdlog/sinks/stdout_color_sinks.h>

#include <memory>
#include <string>

namespace ccfr {

namespace {
std::string& level_override() {
  static std::string level;
  return level;
}
}  // namespace

void init_logging(std::string_view level) {
  // spdlog's default logger writes to stdout; logs belong on stderr so that `ccfr run ... > file`
  // keeps the results apart. Sinks added by the caller (tests count warnings) are kept.
  auto logger = spdlog::default_logger();
  if (logger->name() != "ccfr") {
    auto replacement =
        std::make_shared<spdlog::logger>("ccfr", std::make_shared<spdlog::sinks::stderr_color_sink_mt>());
    for (const auto& sink : logger->sinks())
      if (!std::dynamic_pointer_cast<spdlog::sinks::stdout_color_sink_mt>(sink)) replacement->sinks().push_back(sink);
    spdlog::set_default_logger(replacement);
  }
  spdlog::set_pattern("[%H:%M:%S.%e] [%^%l%$] %v");
  const std::string chosen = level_override().empty() ? std::string(level) : level_override();
  spdlog::set_level(spdlog::level::from_str(chosen));
}

void set_log_level_override(std::string_view level) { level_override() = std::string(level); }

}  // namespace ccfr
