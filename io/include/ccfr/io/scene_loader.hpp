#pragma once
/// @file scene_loader.hpp
/// Loading YAML scene files, strictly: unknown keys, wrong types, out-of-range values and missing
/// mesh files are ccfr::ConfigError naming the file, the key path and the line.
#include <filesystem>
#include <string>
#include <vector>

#include "ccfr/solvers/scene.hpp"

namespace ccfr::io {

struct LoadedScene {
  Scene scene;
  std::string resolved_json;          ///< the configuration with every default filled in, as JSON
  std::filesystem::path source;       ///< the scene file
};

/// Loads `file`, applying `overrides` ("key.path=value", value parsed as YAML) before validation.
LoadedScene load_scene(const std::filesystem::path& file, const std::vector<std::string>& overrides = {});
/// Same, from YAML text; `file_label` names it in errors and relative mesh paths resolve from `base_dir`.
LoadedScene load_scene_text(const std::string& yaml, const std::string& file_label,
                            const std::filesystem::path& base_dir, const std::vector<std::string>& overrides = {});
/// Markdown table of every scene key (type, default, range, meaning), generated from the schema.
std::string config_reference_markdown();

}  // namespace ccfr::io
