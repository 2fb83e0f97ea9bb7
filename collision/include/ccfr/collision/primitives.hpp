#pragma once
/// @file primitives.hpp
/// The collision primitives of a scene and their broad-phase boxes.
///
/// Primitives are laid out in three contiguous ranges: triangles (every face of the Topology:
/// cloth, shells, tet-solid boundaries, obstacles, rigids), then strand segments (the edges that
/// follow the face edges), then points (particle vertices and strand vertices that belong to no
/// segment). Each vertex and each edge is assigned to exactly one incident primitive, its
/// representative (Curtis et al. 2008, "Fast collision detection for deformable models using
/// representative-triangles"), so that a pass over primitive pairs tests every vertex-face and
/// edge-edge sub-pair exactly once.
#include <cstdint>
#include <span>
#include <vector>

#include "ccfr/core/topology.hpp"
#include "ccfr/geometry/aabb.hpp"

namespace ccfr {

enum class PrimitiveKind : std::uint8_t { triangle = 0, edge = 1, point = 2 };

struct CollisionPrimitives {
  Index num_triangles = 0;       ///< primitives [0, num_triangles) are faces, primitive id = face id
  Index num_edges = 0;           ///< primitives [num_triangles, +num_edges) are strand segments
  Index num_points = 0;          ///< the remaining primitives are points
  std::vector<Index> edge_ids;   ///< #num_edges: global edge id of each strand-segment primitive
  std::vector<Index> point_ids;  ///< #num_points: vertex id of each point primitive

  /// #F: bits 0-2 set when the face represents its vertex 0-2; bits 3-5 when it represents its
  /// edge face_edges[f][0-2]. A vertex or edge shared by several faces is represented by the
  /// lowest-numbered one.
  std::vector<std::uint8_t> face_owns;
  /// #num_edges: bits 0-1 set when the segment represents its endpoint edges[e][0-1]. A strand
  /// vertex is represented by its lowest-numbered segment.
  std::vector<std::uint8_t> segment_owns;
  /// #F: true when the face's object must not collide with itself (rigid bodies and obstacles
  /// move as a whole, so their own triangles never approach each other).
  std::vector<std::uint8_t> face_no_self;

  Index size() const { return num_triangles + num_edges + num_points; }
  PrimitiveKind kind(Index p) const {
    return p < num_triangles ? PrimitiveKind::triangle
                             : (p < num_triangles + num_edges ? PrimitiveKind::edge : PrimitiveKind::point);
  }
  /// Face id, global edge id or vertex id of primitive `p`, by kind.
  Index element(Index p) const {
    if (p < num_triangles) return p;
    if (p < num_triangles + num_edges) return edge_ids[static_cast<size_t>(p - num_triangles)];
    return point_ids[static_cast<size_t>(p - num_triangles - num_edges)];
  }
};

/// Collects the primitives of `topo` and assigns representatives.
CollisionPrimitives build_collision_primitives(const Topology& topo);

/// Half-width added to every primitive box: \f$ r + \xi/2 + \delta/2 \f$ (paper §4.1,
/// "Implementation Details"), so two boxes overlap whenever the primitives are closer than
/// \f$ 2r + \xi + \delta \f$, the search range plus the repulsion band.
double box_inflation(double radius, double offset, double repulsion_range);

/// One box per primitive (#P) around the positions `x`, inflated by `inflation`, plus, where
/// `vertex_reach` is given (#V, m), the largest reach of the primitive's vertices: two boxes then
/// overlap whenever the primitives are closer than the sum of their reaches plus 2 `inflation`.
/// Parallel.
void compute_primitive_boxes(const CollisionPrimitives& prims, const Topology& topo, const Positions& x,
                             double inflation, std::vector<AABB>& boxes, std::span<const double> vertex_reach = {});

}  // namespace ccfr
