#include "ccfr/collision/primitives.hpp"

#include <algorithm>
#include <limits>

#include "ccfr/core/parallel.hpp"

namespace ccfr {

CollisionPrimitives build_collision_primitives(const Topology& topo) {
  CollisionPrimitives p;
  const Index nv = topo.num_vertices();
  const Index nf = topo.num_faces();
  p.num_triangles = nf;

  // Representative faces: lowest incident face per vertex and per edge.
  p.face_owns.assign(static_cast<size_t>(nf), 0);
  p.face_no_self.assign(static_cast<size_t>(nf), 0);
  std::vector<std::uint8_t> vertex_taken(static_cast<size_t>(nv), 0);
  std::vector<std::uint8_t> edge_taken(static_cast<size_t>(topo.num_edges()), 0);
  for (Index f = 0; f < nf; ++f) {
    for (int k = 0; k < 3; ++k) {
      const Index v = topo.faces[f][k];
      if (!vertex_taken[v]) {
        vertex_taken[v] = 1;
        p.face_owns[f] |= static_cast<std::uint8_t>(1u << k);
      }
      const Index e = topo.face_edges[f][k];
      if (!edge_taken[e]) {
        edge_taken[e] = 1;
        p.face_owns[f] |= static_cast<std::uint8_t>(8u << k);
      }
    }
    const ObjectKind kind = topo.objects[topo.face_object[f]].kind;
    p.face_no_self[f] = (kind == ObjectKind::rigid || kind == ObjectKind::obstacle) ? 1 : 0;
  }

  // Strand segments: the edges not used by any face (TopologyBuilder puts them after the face
  // edges); their vertices go to the lowest segment.
  for (Index e = 0; e < topo.num_edges(); ++e) {
    if (edge_taken[e]) continue;
    p.edge_ids.push_back(e);
    std::uint8_t owns = 0;
    for (int k = 0; k < 2; ++k) {
      const Index v = topo.edges[e][k];
      if (!vertex_taken[v]) {
        vertex_taken[v] = 1;
        owns |= static_cast<std::uint8_t>(1u << k);
      }
    }
    p.segment_owns.push_back(owns);
  }
  p.num_edges = static_cast<Index>(p.edge_ids.size());

  // Points: particle vertices, and strand vertices of one-vertex polylines (no segment).
  for (Index v = 0; v < nv; ++v) {
    if (vertex_taken[v]) continue;
    const ObjectKind kind = topo.object_of_vertex(v).kind;
    if (kind == ObjectKind::particles || kind == ObjectKind::strand) p.point_ids.push_back(v);
  }
  p.num_points = static_cast<Index>(p.point_ids.size());
  return p;
}

double box_inflation(double radius, double offset, double repulsion_range) {
  return radius + 0.5 * offset + 0.5 * repulsion_range;
}

void compute_primitive_boxes(const CollisionPrimitives& prims, const Topology& topo, const Positions& x,
                             double inflation, std::vector<AABB>& boxes, std::span<const double> vertex_reach) {
  const bool per_vertex = !vertex_reach.empty();
  auto reach = [&](Index v) { return per_vertex ? vertex_reach[v] : 0.0; };
  boxes.resize(static_cast<size_t>(prims.size()));
  parallel_for(
      prims.size(),
      [&](Index begin, Index end) {
        for (Index p = begin; p < end; ++p) {
          AABB b;
          bool finite = true;
          double grow = inflation;
          switch (prims.kind(p)) {
            case PrimitiveKind::triangle: {
              const Vec3i& f = topo.faces[p];
              b = AABB::of(x[f[0]], x[f[1]], x[f[2]]);
              grow += std::max({reach(f[0]), reach(f[1]), reach(f[2])});
              finite = x[f[0]].allFinite() && x[f[1]].allFinite() && x[f[2]].allFinite();
              break;
            }
            case PrimitiveKind::edge: {
              const Vec2i& e = topo.edges[prims.element(p)];
              b = AABB::of(x[e[0]], x[e[1]]);
              grow += std::max(reach(e[0]), reach(e[1]));
              finite = x[e[0]].allFinite() && x[e[1]].allFinite();
              break;
            }
            case PrimitiveKind::point:
              b = AABB::of(x[prims.element(p)]);
              grow += reach(prims.element(p));
              finite = x[prims.element(p)].allFinite();
              break;
          }
          b.inflate(grow);
          // cwiseMin/cwiseMax may drop a NaN operand; mark the box so the broad phase rejects it.
          if (!finite) b.lo.setConstant(std::numeric_limits<double>::quiet_NaN());
          boxes[p] = b;
        }
      },
      1024);
}

}  // namespace ccfr
