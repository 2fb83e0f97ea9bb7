#pragma once
/// @file log.hpp
/// ccfr's logging and string formatting: `ccfr::log::info("{} of {}", a, b)` and
/// `ccfr::format(...)` with fmt-style fields (`{}`, `{:.4g}`, `{:>8}`). Log lines go to stderr
/// (stdout carries results only). spdlog and fmt are private details of ccfr::core: no header of
/// theirs appears here, so a program linking ccfr needs neither (GCC 12's libstdc++ has no
/// std::format, which would otherwise do the formatting).
#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <type_traits>

namespace ccfr {

/// Configures the default logger: level name (trace, debug, info, warn, error, off). A level
/// fixed by set_log_level_override() wins over `level`, the caller's default.
void init_logging(std::string_view level = "info");

/// Fixes the level for every later init_logging() call (the command line's --log-level or
/// --quiet, which apply whatever default a subcommand asks for); empty clears it.
void set_log_level_override(std::string_view level);

/// One argument of ccfr::format, type-erased so that the formatting library stays inside core.
/// Strings are referenced, not copied: a FormatArg lives only as long as the call it is made for.
class FormatArg {
 public:
  enum class Kind : std::uint8_t { Bool, Char, Int, UInt, Float, Double, String, Pointer };

  template <class T>
  FormatArg(const T& v) {  // NOLINT(google-explicit-constructor): built from the call's arguments
    using U = std::remove_cvref_t<T>;
    if constexpr (std::is_same_v<U, bool>) {
      kind_ = Kind::Bool;
      u_ = v ? 1 : 0;
    } else if constexpr (std::is_same_v<U, char>) {
      kind_ = Kind::Char;
      i_ = v;
    } else if constexpr (std::is_integral_v<U> && std::is_signed_v<U>) {
      kind_ = Kind::Int;
      i_ = v;
    } else if constexpr (std::is_integral_v<U>) {
      kind_ = Kind::UInt;
      u_ = v;
    } else if constexpr (std::is_same_v<U, float>) {
      // Kept apart from double: the shortest form of a float is not that of the same double.
      kind_ = Kind::Float;
      f_ = v;
    } else if constexpr (std::is_floating_point_v<U>) {
      kind_ = Kind::Double;
      d_ = static_cast<double>(v);
    } else if constexpr (std::is_convertible_v<const U&, std::string_view>) {
      kind_ = Kind::String;
      s_ = std::string_view(v);
    } else if constexpr (std::is_pointer_v<U>) {
      kind_ = Kind::Pointer;
      p_ = static_cast<const void*>(v);
    } else {
      static_assert(sizeof(U) == 0, "ccfr::format: pass numbers, strings or pointers (convert others first)");
    }
  }

  Kind kind() const { return kind_; }
  bool as_bool() const { return u_ != 0; }
  char as_char() const { return static_cast<char>(i_); }
  std::int64_t as_int() const { return i_; }
  std::uint64_t as_uint() const { return u_; }
  float as_float() const { return f_; }
  double as_double() const { return d_; }
  std::string_view as_string() const { return s_; }
  const void* as_pointer() const { return p_; }

 private:
  Kind kind_ = Kind::Int;
  std::int64_t i_ = 0;
  std::uint64_t u_ = 0;
  float f_ = 0;
  double d_ = 0;
  std::string_view s_;
  const void* p_ = nullptr;
};

namespace detail {
/// Called only when a format string's fields and the arguments disagree: not constexpr, so the
/// consteval check below fails to compile, naming this function.
void format_fields_do_not_match_the_arguments();

/// The number of arguments the fields of `f` need: automatic fields count in order, `{n}` needs
/// n + 1; `{{` and `}}` are literal braces.
consteval std::size_t format_arguments_needed(std::string_view f) {
  std::size_t automatic = 0, needed = 0;
  for (std::size_t i = 0; i < f.size(); ++i) {
    if (f[i] == '}') {
      if (i + 1 < f.size() && f[i + 1] == '}') ++i;
      continue;
    }
    if (f[i] != '{') continue;
    if (i + 1 < f.size() && f[i + 1] == '{') {
      ++i;
      continue;
    }
    std::size_t j = i + 1;
    if (j < f.size() && f[j] >= '0' && f[j] <= '9') {
      std::size_t n = 0;
      while (j < f.size() && f[j] >= '0' && f[j] <= '9') n = 10 * n + static_cast<std::size_t>(f[j++] - '0');
      needed = n + 1 > needed ? n + 1 : needed;
    } else {
      ++automatic;
      needed = automatic > needed ? automatic : needed;
    }
    while (j < f.size() && f[j] != '}') ++j;
    i = j;
  }
  return needed;
}
}  // namespace detail

/// A format string checked at compile time against its argument count (the field syntax itself
/// is checked when formatting: a malformed field is a ccfr::Error naming the string).
template <class... Args>
struct FormatString {
  template <class S>
    requires std::is_convertible_v<const S&, std::string_view>
  consteval FormatString(const S& s) : text(s) {  // NOLINT(google-explicit-constructor)
    if (detail::format_arguments_needed(text) != sizeof...(Args)) detail::format_fields_do_not_match_the_arguments();
  }
  std::string_view text;
};

/// Formats `f` with `args` (fmt's syntax). Throws ccfr::Error for a malformed field or an
/// argument that does not fit its field (`{:d}` of a string).
std::string vformat(std::string_view f, std::span<const FormatArg> args);

template <class... Args>
std::string format(FormatString<std::type_identity_t<Args>...> f, const Args&... args) {
  const std::array<FormatArg, sizeof...(Args)> a{FormatArg(args)...};
  return vformat(f.text, a);
}

namespace log {

enum class Level { trace, debug, info, warn, error, off };

/// Whether a message at `level` would be written (to skip building an expensive one).
bool enabled(Level level);
/// Writes one finished message at `level`.
void write(Level level, std::string_view message);
/// Formats and writes one message at `level`. Never throws: a field that does not fit its
/// argument is written as the format string with a note, because a log line must not stop a run.
void write_formatted(Level level, std::string_view f, std::span<const FormatArg> args) noexcept;

template <class... Args>
void trace(FormatString<std::type_identity_t<Args>...> f, const Args&... args) {
  if (!enabled(Level::trace)) return;
  const std::array<FormatArg, sizeof...(Args)> a{FormatArg(args)...};
  write_formatted(Level::trace, f.text, a);
}
template <class... Args>
void debug(FormatString<std::type_identity_t<Args>...> f, const Args&... args) {
  if (!enabled(Level::debug)) return;
  const std::array<FormatArg, sizeof...(Args)> a{FormatArg(args)...};
  write_formatted(Level::debug, f.text, a);
}
template <class... Args>
void info(FormatString<std::type_identity_t<Args>...> f, const Args&... args) {
  if (!enabled(Level::info)) return;
  const std::array<FormatArg, sizeof...(Args)> a{FormatArg(args)...};
  write_formatted(Level::info, f.text, a);
}
template <class... Args>
void warn(FormatString<std::type_identity_t<Args>...> f, const Args&... args) {
  if (!enabled(Level::warn)) return;
  const std::array<FormatArg, sizeof...(Args)> a{FormatArg(args)...};
  write_formatted(Level::warn, f.text, a);
}
template <class... Args>
void error(FormatString<std::type_identity_t<Args>...> f, const Args&... args) {
  if (!enabled(Level::error)) return;
  const std::array<FormatArg, sizeof...(Args)> a{FormatArg(args)...};
  write_formatted(Level::error, f.text, a);
}

}  // namespace log
}  // namespace ccfr
