#pragma once
// What the scene builder's readers share (scene_loader.cpp's Builder runs them in order): where an
// error points (the input as written, for its lines), the resolved configuration, and the
// geometry of an object before placement. One reader per schema section, in io/src/scene/.
#include <filesystem>
#include <functional>
#include <map>
#include <string>
#include <vector>

#include "../schema.hpp"
#include "ccfr/core/topology.hpp"
#include "ccfr/io/scene_loader.hpp"
#include "ccfr/solvers/params.hpp"

namespace ccfr::io::scene {

namespace fs = std::filesystem;

inline Vec3 v3(const YAML::Node& n) { return Vec3(n[0].as<double>(), n[1].as<double>(), n[2].as<double>()); }

/// Geometry of one object before placement.
struct RawGeometry {
  Positions v;
  std::vector<Vec3i> faces;
  std::vector<Vec4i> tets;
  std::vector<std::vector<Index>> lines;
  AnalyticShape shape;
};

/// The scene being read: the input as written (line numbers), the resolved tree (defaults filled
/// by the schema), the error context, the folder relative paths start from, in-memory meshes.
struct Input {
  const YAML::Node& in;
  const YAML::Node& cfg;
  const schema::Context& ctx;
  fs::path base;
  const std::map<std::string, MeshArrays>* arrays = nullptr;

  /// The input node at a resolved key path (for line numbers of cross-field errors).
  YAML::Node in_node(const std::string& path) const;
};

/// Why a name cannot be written as `o name` in the OBJ frames (empty when it can).
std::string name_problem(const std::string& name, bool whitespace_matters);

// sections.cpp: the global sections and materials.
/// scene, max_memory (returned, GB), time, contact, collision, debug, output.
double read_globals(const Input& in, SimulationParams& p);
/// The material an object names (`path`: its key path), or the implicit default.
MaterialParams read_material(const Input& in, const std::string& name, const std::string& path);

// scripts.cpp: what moves an object or holds it.
/// A motion section (resolved); a default Motion when absent.
Motion read_motion(const YAML::Node& m);
/// Scripted motion moves from `start` to `end`: an end before the start would never move.
void check_motion(const Input& in, const YAML::Node& m, const std::string& mpath);
/// objects[i].animation: an obstacle animated by an OBJ sequence.
void read_animation(const Input& in, const YAML::Node& o, const ObjectInfo& info, SimState& st, ObjectParams& op,
                    const std::string& path);
/// objects[i].keyframes: an obstacle moved by keyframed rigid transforms.
void read_keyframes(const Input& in, const YAML::Node& o, const ObjectInfo& info, SimState& st, ObjectParams& op,
                    const std::string& path);
/// objects[i].pins.
void read_pins(const Input& in, const YAML::Node& pins, const ObjectInfo& info, SimState& st, ObjectParams& op,
               const std::string& path);

// shapes.cpp: objects[i].shape, one reader per geometry source.
/// The geometry of `shape` for an object of `kind` at key path `path` (objects[i]); `scale`: its
/// transform.scale, applied later by place (tetgen's volume bound is in the file's units).
RawGeometry read_shape(const Input& in, const YAML::Node& shape, ObjectKind kind, const std::string& path,
                       double scale);
/// True for the kinds made of a triangle surface.
bool surface_kind(ObjectKind kind);

// mesh_sources.cpp: shape type mesh (a file, or in-memory arrays).
RawGeometry read_mesh_file(const Input& in, const YAML::Node& s, ObjectKind kind, const std::string& path, double scale,
                           const std::function<void(bool, const std::string&)>& require);
RawGeometry read_mesh_arrays(const Input& in, const MeshArrays& a, ObjectKind kind, const std::string& path,
                             const std::function<void(bool, const std::string&)>& require);

// placement.cpp: face checks and objects[i].transform.
/// Degenerate surfaces (see the definition); `lines`: the file line of each face, if known.
void check_faces(const Input& in, const Positions& v, const std::vector<Vec3i>& faces, ObjectKind kind,
                 const std::string& what, const std::vector<int>* lines, const std::string& path,
                 const std::vector<std::string>& related);
/// A rotation by a non-zero angle about the zero vector has no axis.
void check_rotation(const Input& in, const YAML::Node& t, const std::string& tpath);
/// Placed coordinates beyond kMaxCoordinate are refused, naming the vertex.
void check_placed(const Input& in, const Positions& v, const std::string& path, const std::string& name);
/// Scale, rotate, then translate by the transform section `t`.
void place(RawGeometry& g, const YAML::Node& t);

// masses.cpp
/// Vertex masses from each object's material density; pinned and obstacle vertices immovable.
void compute_masses(const Input& in, Scene& scene);

// yaml_text.cpp
/// Parses the text of a scene file: printable text, one YAML document, every quoted string closed.
YAML::Node parse_yaml(const std::string& text, const std::string& label, const std::string& what = "scene file");

}  // namespace ccfr::io::scene
