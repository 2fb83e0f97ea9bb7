#pragma once
/// @file topology.hpp
/// The scene model: one flat vertex array for every object, per-object ranges and kinds, global
/// edge / face / tet index arrays, and per-vertex incidence in CSR form.
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "ccfr/core/csr.hpp"
#include "ccfr/core/types.hpp"

namespace ccfr {

/// What an object is; decides its constraints, its collision primitives and how it is written.
enum class ObjectKind : std::uint8_t {
  cloth,      ///< triangle sheet: stretch + bending, two-sided contact
  shell,      ///< closed or open triangle surface treated like cloth (paper, thin shells)
  tet_solid,  ///< tetrahedral volume; its boundary triangles collide
  strand,     ///< polylines (hair, wires, rods); segments collide as edges
  particles,  ///< free points; vertices collide as points
  obstacle,   ///< kinematic triangle mesh with scripted motion (inverse mass 0)
  rigid,      ///< closed triangle surface moved as one body (shape matching)
};

std::string_view to_string(ObjectKind kind);
std::optional<ObjectKind> object_kind_from_string(std::string_view name);
/// All kinds by name, for error messages and docs.
const std::vector<std::string_view>& object_kind_names();

/// One object's slice of the global arrays (half-open ranges).
struct ObjectInfo {
  std::string name;
  ObjectKind kind = ObjectKind::cloth;
  Index vertex_begin = 0, vertex_end = 0;
  Index face_begin = 0, face_end = 0;          ///< rows of Topology::faces
  Index tet_begin = 0, tet_end = 0;            ///< rows of Topology::tets
  Index polyline_begin = 0, polyline_end = 0;  ///< rows of Topology::polylines

  Index num_vertices() const { return vertex_end - vertex_begin; }
  bool kinematic() const { return kind == ObjectKind::obstacle; }
};

/// Connectivity of the whole scene. Built once with TopologyBuilder; never changes in a run.
struct Topology {
  std::vector<ObjectInfo> objects;
  std::vector<Index> vertex_object;  ///< #V: owning object of each vertex
  std::vector<Vec3i> faces;          ///< #F by 3, surface triangles (cloth, shells, tet boundaries, obstacles, rigids)
  std::vector<Vec2i> edges;          ///< #E by 2, unique undirected edges (a < b): face edges, then strand segments
  std::vector<Vec4i> tets;           ///< #T by 4, positively oriented tetrahedra
  Csr polylines;                     ///< one row per strand: its vertex sequence
  std::vector<Vec3i> face_edges;     ///< #F by 3: edge ids of (v0,v1), (v1,v2), (v2,v0)
  std::vector<Index> edge_object;    ///< #E: owning object
  std::vector<Index> face_object;    ///< #F: owning object
  Csr vertex_faces;                  ///< #V rows: incident faces
  Csr vertex_edges;                  ///< #V rows: incident edges

  Index num_vertices() const { return static_cast<Index>(vertex_object.size()); }
  Index num_faces() const { return static_cast<Index>(faces.size()); }
  Index num_edges() const { return static_cast<Index>(edges.size()); }
  const ObjectInfo& object_of_vertex(Index v) const { return objects[vertex_object[v]]; }
  /// Finds an object by name; nullptr if absent.
  const ObjectInfo* find_object(std::string_view name) const;
};

/// Appends objects with local (0-based) indices and finalises the global arrays.
class TopologyBuilder {
 public:
  /// Adds an object; its local indices are shifted by the vertices added so far.
  /// Returns the object index. For tet solids pass the tets; the boundary faces are derived.
  Index add_object(std::string name, ObjectKind kind, Index num_vertices, const std::vector<Vec3i>& faces = {},
                   const std::vector<Vec4i>& tets = {}, const std::vector<std::vector<Index>>& polylines = {});
  /// Builds unique edges, face-edge incidence and CSR adjacency.
  Topology finish();

 private:
  Topology topo_;
  std::vector<std::vector<Index>> polylines_;
};

/// Boundary triangles of a tet mesh, oriented outward (faces used by exactly one tet).
std::vector<Vec3i> tet_boundary(const std::vector<Vec4i>& tets);

}  // namespace ccfr
