#pragma once
// The ConfigError a scene raises, shared by the loader's tests (three suites asked the same).
#include <gtest/gtest.h>

#include <filesystem>
#include <string>
#include <vector>

#include "ccfr/core/error.hpp"
#include "ccfr/io/scene_loader.hpp"

namespace ccfr::test {

/// Loads `yaml` (relative mesh paths from `base`) and returns the ConfigError it raises; fails the
/// test if it loads or raises anything else.
inline ConfigError config_error(const std::string& yaml, const std::vector<std::string>& sets = {},
                                const std::filesystem::path& base = ".") {
  try {
    io::load_scene_text(yaml, "scene.yaml", base, sets);
  } catch (const ConfigError& e) {
    return e;
  } catch (const std::exception& e) {
    ADD_FAILURE() << "expected a ConfigError, got: " << e.what() << "\nfor:\n" << yaml;
    return ConfigError("", "", 0, "");
  }
  ADD_FAILURE() << "expected a ConfigError for:\n" << yaml;
  return ConfigError("", "", 0, "");
}

}  // namespace ccfr::test
