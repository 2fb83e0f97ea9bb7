#pragma once
/// @file scene_loader.hpp
/// Loading YAML scene files, strictly: unknown keys, wrong types, out-of-range values and missing
/// mesh files are ccfr::ConfigError naming the file, the key path and the line.
#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "ccfr/solvers/scene.hpp"

namespace ccfr::io {

struct LoadedScene {
  Scene scene;
  std::string resolved_json;     ///< the configuration with every default filled in, as JSON
  std::filesystem::path source;  ///< the scene file
};

/// Loads `file`, applying `overrides` ("key.path=value", value parsed as YAML) before validation.
LoadedScene load_scene(const std::filesystem::path& file, const std::vector<std::string>& overrides = {});
/// Same, from YAML text; `file_label` names it in errors and relative mesh paths resolve from `base_dir`.
LoadedScene load_scene_text(const std::string& yaml, const std::string& file_label,
                            const std::filesystem::path& base_dir, const std::vector<std::string>& overrides = {});
/// An object's geometry handed over in memory (e.g. NumPy arrays from Python) instead of a file.
/// Indices are 0-based and local to the object.
struct MeshArrays {
  Positions vertices;
  std::vector<Vec3i> faces;  ///< cloth, shell, obstacle, rigid
  std::vector<Vec2i> edges;  ///< strand segments; consecutive edges (a, b), (b, c) chain into one strand
  std::vector<Vec4i> tets;   ///< tet_solid, positively oriented ((b-a)×(c-a)·(d-a) > 0)
};

/// Like load_scene_text, where a shape `{type: mesh, path: NAME}` whose NAME is a key of `arrays`
/// takes those arrays instead of reading a file. They go through the mesh file's checks (finite
/// vertices, indices in range, degenerate and duplicate faces, closed rigid surfaces, ...) plus
/// those of edges and tets; errors are ConfigErrors at `objects[i].vertices`, `.faces`, `.edges`
/// or `.tets`.
LoadedScene load_scene_arrays(const std::string& yaml, const std::string& file_label,
                              const std::map<std::string, MeshArrays>& arrays,
                              const std::vector<std::string>& overrides = {});
/// Checks `file` with `overrides` against the schema (keys, types, ranges, choices) without
/// building the scene: what a sweep validates for each cell before any cell runs.
void check_scene_keys(const std::filesystem::path& file, const std::vector<std::string>& overrides);
/// Markdown table of every scene key (type, default, range, meaning), generated from the schema.
std::string config_reference_markdown();

}  // namespace ccfr::io
