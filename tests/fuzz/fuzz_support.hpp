#pragma once
// Shared by the fuzz targets. Bad input must end in ccfr::Error with a message (the clear,
// user-facing error the CLI prints). Anything else is a finding and aborts, so libFuzzer (or the
// corpus replay under ctest) reports it with the input: a crash, a sanitizer report, a hang, or
// another exception escaping -- YAML::Exception, std::bad_alloc, std::out_of_range, ...
#include <cxxabi.h>
#include <spdlog/spdlog.h>

#include <cstdio>
#include <cstdlib>
#include <exception>
#include <memory>
#include <string>
#include <typeinfo>

#include "ccfr/core/error.hpp"

namespace ccfr::fuzz {

inline std::string demangle(const char* name) {
  int status = 0;
  std::unique_ptr<char, void (*)(void*)> d(abi::__cxa_demangle(name, nullptr, nullptr, &status), std::free);
  return status == 0 && d ? d.get() : name;
}

[[noreturn]] inline void finding(const char* what_ran, const std::string& kind, const std::string& message) {
  std::fprintf(stderr, "\n==ccfr-fuzz== FINDING in %s: %s escaped instead of ccfr::Error: %s\n", what_ran, kind.c_str(),
               message.c_str());
  std::abort();
}

/// Runs `f`; returns true if it succeeded, false if it threw ccfr::Error; aborts otherwise.
template <class F>
bool expect_ccfr_error(const char* what_ran, F&& f) {
  try {
    f();
    return true;
  } catch (const ccfr::Error& e) {
    if (std::string(e.what()).empty()) finding(what_ran, "ccfr::Error with an empty message", "");
    return false;
  } catch (const std::exception& e) {
    finding(what_ran, demangle(typeid(e).name()), e.what());
  } catch (...) {
    finding(what_ran, "a non-std exception", "(no message)");
  }
}

/// Called once before the first input: warnings about odd-but-valid scenes would flood the log.
inline void quiet() { spdlog::set_level(spdlog::level::off); }

}  // namespace ccfr::fuzz
