#include "ccfr/core/log.hpp"

#include <fmt/args.h>
#include <fmt/format.h>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include <memory>
#include <string>

#include "ccfr/core/error.hpp"

namespace ccfr {

namespace {
std::string& level_override() {
  static std::string level;
  return level;
}

spdlog::level::level_enum to_spdlog(log::Level level) {
  switch (level) {
    case log::Level::trace:
      return spdlog::level::trace;
    case log::Level::debug:
      return spdlog::level::debug;
    case log::Level::info:
      return spdlog::level::info;
    case log::Level::warn:
      return spdlog::level::warn;
    case log::Level::error:
      return spdlog::level::err;
    case log::Level::off:
      break;
  }
  return spdlog::level::off;
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

namespace detail {
void format_fields_do_not_match_the_arguments() {}
}  // namespace detail

std::string vformat(std::string_view f, std::span<const FormatArg> args) {
  fmt::dynamic_format_arg_store<fmt::format_context> store;
  store.reserve(args.size(), 0);
  for (const FormatArg& a : args) {
    switch (a.kind()) {
      case FormatArg::Kind::Bool:
        store.push_back(a.as_bool());
        break;
      case FormatArg::Kind::Char:
        store.push_back(a.as_char());
        break;
      case FormatArg::Kind::Int:
        store.push_back(static_cast<long long>(a.as_int()));
        break;
      case FormatArg::Kind::UInt:
        store.push_back(static_cast<unsigned long long>(a.as_uint()));
        break;
      case FormatArg::Kind::Float:
        store.push_back(a.as_float());
        break;
      case FormatArg::Kind::Double:
        store.push_back(a.as_double());
        break;
      case FormatArg::Kind::String:
        store.push_back(a.as_string());
        break;
      case FormatArg::Kind::Pointer:
        store.push_back(a.as_pointer());
        break;
    }
  }
  try {
    return fmt::vformat(fmt::string_view(f.data(), f.size()), store);
  } catch (const fmt::format_error& e) {
    throw Error("format string \"" + std::string(f) + "\": " + e.what());
  }
}

namespace log {

bool enabled(Level level) { return level != Level::off && spdlog::should_log(to_spdlog(level)); }

void write(Level level, std::string_view message) {
  if (level == Level::off) return;
  spdlog::log(to_spdlog(level), "{}", message);
}

void write_formatted(Level level, std::string_view f, std::span<const FormatArg> args) noexcept {
  try {
    write(level, vformat(f, args));
  } catch (const std::exception& e) {
    try {
      write(level, std::string(f) + " [not formatted: " + e.what() + "]");
    } catch (...) {  // the sink itself failed (out of memory): nothing left to tell
    }
  }
}

}  // namespace log
}  // namespace ccfr
