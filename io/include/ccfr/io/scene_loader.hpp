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

/// The loader's estimate of a run's peak resident memory (docs/choosing-parameters.md, "Memory"):
/// a scene whose estimate exceeds the limit (max_memory, else MemAvailable) is refused before it is
/// built. With V vertices, F surface faces, T tets, E strand segments of an object, h its mean edge
/// length, R = ξ + r + δ its contact range and D = 2r + ξ + δ the detection reach, an object costs
///   deformable:  kBytesPerVertex V + kBytesPerFace F + kBytesPerTet T + kBytesPerSegment E
///                + kBytesPerCrowdedVertex V (R / h)^2   (strands: (R / h)^1; self-contact)
///   rigid body, obstacle:  kBytesPerBodyVertex V + kBytesPerBodyFace F
///                + kBytesPerContactUnit V min(1, D / (2 rho)) (2 + D / h_p)^2   (contact with others)
/// where h_p is the smallest mean edge length of the objects it can touch (every other object but
/// an obstacle's fellow obstacles; particles, without edges, count as (2 + D / h_p)^2 = 1), and
/// rho = 3 volume / area of its closed surface (a sphere's radius; an open surface has share 1).
/// A vertex within reach of a surface holds a half-space per primitive of that surface within D
/// plus its nearest ring, about (2 + D / h_p)^2 of them up to a constant; a body resting on a
/// curved neighbour has a share of about D / (2 rho) of its surface within reach. A body that can
/// touch nothing pays no contact term. The scene adds kBaseBytes. Checked against the peak RSS
/// of scenes of every kind in docs/performance.md.
namespace memory_model {
inline constexpr double kBaseBytes = 26e6;
inline constexpr double kBytesPerVertex = 4096;
inline constexpr double kBytesPerCrowdedVertex = 16384;
inline constexpr double kBytesPerFace = 512;
inline constexpr double kBytesPerTet = 1024;
inline constexpr double kBytesPerSegment = 512;
inline constexpr double kBytesPerBodyVertex = 1024;
inline constexpr double kBytesPerBodyFace = 256;
inline constexpr double kBytesPerContactUnit = 2304;  ///< calibrated: docs/performance.md (issue 39)
}  // namespace memory_model

/// What one object is charged (see memory_model).
struct ObjectMemory {
  std::string name;
  double vertices = 0, faces = 0, tets = 0, segments = 0;
  double mean_edge = 0;     ///< h (0: the object has no edges)
  double crowd = 0;         ///< deformables: V (R / h)^2 (strands: V R / h)
  double partner_edge = 0;  ///< bodies: h_p (infinity: only particles to touch; 0: nothing to touch)
  double body_radius = 0;   ///< bodies: rho = 3 volume / area (0: open surface)
  double contact = 0;       ///< bodies: V min(1, D / (2 rho)) (2 + D / h_p)^2
  double bytes = 0;         ///< the object's share of the estimate
};

struct MemoryEstimate {
  std::vector<ObjectMemory> objects;
  double total_bytes = 0;  ///< memory_model::kBaseBytes plus every object's bytes
};

struct LoadedScene {
  Scene scene;
  MemoryEstimate memory;         ///< the estimate the scene was admitted with
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
