#pragma once
/// @file scene_loader.hpp
/// Loading YAML scene files, strictly: unknown keys, wrong types, out-of-range values and missing
/// mesh files are ccfr::ConfigError naming the file, the key path and the line.
#include <filesystem>
#include <functional>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "ccfr/core/error.hpp"
#include "ccfr/solvers/scene.hpp"

namespace ccfr::io {

/// The most frames a scene runs (time.frames, output.every, output.checkpoint_every; `--frames`).
inline constexpr long long kMaxFrames = 10000000;

/// The loader's estimate of a run's peak resident memory (docs/choosing-parameters.md, "Memory"):
/// a scene whose estimate exceeds the limit (max_memory, else MemAvailable) is refused before it is
/// built, and `ccfr run` stops cleanly if the run outgrows the limit anyway. Peak RSS is the
/// process base, about 1 KB per element and 170-270 bytes per half-space of the densest detection
/// pass (measured on 17 scenes, docs/performance.md); the contact units predict the half-spaces.
/// With D = 2r + ξ + δ the detection reach, and per object V vertices, F surface faces, T tets, E
/// strand segments, S the vertices that collide (a tet solid's boundary), h the mean edge and A
/// the area of what collides (strands: S h²), ρ = 3 volume / area of a closed body surface:
///   elements:  kBytesPerVertex V + kBytesPerFace F + kBytesPerTet T + kBytesPerSegment E
///              (rigid bodies and obstacles: kBytesPerBodyVertex V + kBytesPerBodyFace F)
///   self:      per vertex that collides, h_v its mean edge: kBytesPerFineUnit (D / h_v)^2 of a
///              surface (a sheet or a tet boundary finer than D pairs with its own flat
///              neighbourhood; its thin parts add, per vertex, the vertices within D whose normals
///              face it, over the 2π/√3 vertices of one unit: a scan's fingers, a folded sheet),
///              plus kBytesPerDrivenUnit (1 + D / h_v)^2 when scripted pins move it
///              (it can be wound onto itself, like the twisting cloth); each vertex's term at
///              most the object's colliding vertices + edges + faces; kBytesPerStrandSelfUnit
///              (1 + D / h_v) of strands; kBytesPerGrainUnit per pair of particles of one object
///              within D of each other as loaded, counted from both sides
///   cross:     kBytesPerCrossUnit S sum_j min(1, A_j / A) F_j, for every other object j when either
///              side is deformable, F_j = ((h + h_j) / 2 + D)^2 / h_j^2 (1 for particles), the shares
///              min(1, A_j / A) summing to at most 2 layers (a sheet among other sheets: the
///              layers kept ξ apart that a stack packs within D, 2 sum_k (h + sqrt(D^2 - (k xi)^2))^2
///              over the nearest's, k = 1 .. floor(D / xi); a sheet moved by scripted pins has its
///              share min(1, A_j / A) times half that sum, the layers a bunch of it packs per side)
///   patch:     kBytesPerPatchUnit max_j min(2 pi D rho_eff, A, A_j) / h^2 F_j of a rigid body
///              against other bodies j, rho_eff = rho rho_j / (rho + rho_j) (an open surface: rho)
/// Obstacles hold no half-spaces (their vertices never move) and pay elements only. The scene adds
/// kBaseBytes.
namespace memory_model {
inline constexpr double kBaseBytes = 17.5e6;
inline constexpr double kBytesPerVertex = 500;
inline constexpr double kBytesPerFace = 200;
inline constexpr double kBytesPerTet = 300;
inline constexpr double kBytesPerSegment = 100;
inline constexpr double kBytesPerBodyVertex = 1200;
inline constexpr double kBytesPerBodyFace = 600;
inline constexpr double kBytesPerFineUnit = 10300;
inline constexpr double kBytesPerDrivenUnit = 3600;
inline constexpr double kBytesPerGrainUnit = 180;
inline constexpr double kBytesPerStrandSelfUnit = 8200;
inline constexpr double kBytesPerCrossUnit = 4800;
inline constexpr double kBytesPerPatchUnit = 20700;
}  // namespace memory_model

/// What one object is charged (see memory_model).
struct ObjectMemory {
  std::string name;
  double vertices = 0, faces = 0, tets = 0, segments = 0;
  double mean_edge = 0;       ///< h of what collides (0: no edges)
  double area = 0;            ///< A of what collides
  double body_radius = 0;     ///< bodies: rho = 3 volume / area (0: open surface)
  double fine_contact = 0;    ///< fine units
  double driven_contact = 0;  ///< driven units (a surface with scripted pins)
  double strand_contact = 0;  ///< strand units
  double grain_contact = 0;   ///< particles: neighbours within D, summed over the particles
  double cross_contact = 0;   ///< cross units
  double patch_contact = 0;   ///< patch units (rigid bodies)
  double bytes = 0;           ///< the object's share of the estimate
};

struct MemoryEstimate {
  std::vector<ObjectMemory> objects;
  double total_bytes = 0;  ///< memory_model::kBaseBytes plus every object's bytes
  /// What the run may hold: max_memory, else MemAvailable when the scene was loaded plus what this
  /// process held then (0: unknown, no limit). `ccfr run` stops cleanly when its resident memory
  /// passes it after a frame (docs/output.md), because an estimate can err low.
  double limit_bytes = 0;
  bool limit_is_max_memory = false;     ///< the limit is max_memory (else the machine's)
  bool limit_from_environment = false;  ///< lowered for one run by CCFR_RUN_MEMORY_LIMIT_MB
};

struct LoadedScene {
  Scene scene;
  MemoryEstimate memory;         ///< the estimate the scene was admitted with
  std::string resolved_json;     ///< the configuration with every default filled in, as JSON
  std::filesystem::path source;  ///< the scene file
  /// The loader's locator (see rethrow_located): throws the ConfigError at a key path, with the
  /// file (or the `--set` that set the key) and line. Empty for a scene built in code.
  std::function<void(const std::string& key_path, const std::string& message)> fail_at;
};

/// Rethrows `e`, raised after loading by a component's own check (when the simulation starts, e.g.
/// `contact.dat.query_radius: 1e+300 must be ...`), as a ConfigError naming the scene file, the key
/// path and its line as the schema's errors do, when its message starts with a key path of the
/// scene ("KEY.PATH: "); otherwise rethrows `e` unchanged. Call it from the handler of `e`.
[[noreturn]] void rethrow_located(const LoadedScene& scene, const Error& e);

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

/// The scene keys read into C++ enums and flags through a choice table (time.continuation,
/// contact.on_violation, debug.audit, objects.shape.layout of strands), each with the choices the
/// schema offers for it, in the schema's order (tests load each one and check its value).
std::vector<std::pair<std::string, std::vector<std::string>>> table_choices();
/// Where the scene readers and the schema disagree, one line each: a key read through a choice
/// table whose schema choices are not the table's (or whose table repeats a string or a value),
/// a shape type of the schema without a reader, a reader without a shape type. Empty: they agree.
std::vector<std::string> reader_schema_mismatches();

}  // namespace ccfr::io
