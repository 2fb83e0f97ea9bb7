#pragma once
/// @file adjacency.hpp
/// Topological adjacency of sub-pairs (design clarification 5, corrected): the only pairs that
/// may be excluded from contact for a whole run. A mesh whose edges are shorter than ξ has
/// vertex-face and edge-edge sub-pairs closer than ξ at rest between primitives a few rings
/// apart; pushing those to ξ would tear the sheet apart. Everything else that starts closer than ξ
/// (two objects that merely start close, the layers of a folded cloth) keeps contact, with its own
/// reduced offset (docs/collision.md, "Initial proximity").
#include <cstdint>
#include <span>
#include <vector>

#include "ccfr/core/csr.hpp"
#include "ccfr/core/topology.hpp"
#include "ccfr/core/types.hpp"

namespace ccfr {

/// Path length bound of adjacency in units of ξ: two vertices are adjacent when a path along the
/// edges of their object, measured at rest, is at most kAdjacencyRadiusInOffsets · ξ long.
/// Two because on a regular sheet an edge path is at most √2 times the straight line, plus slack
/// for the closest point lying inside a primitive rather than at its nearest vertex.
inline constexpr double kAdjacencyRadiusInOffsets = 2.0;

/// Initial proximity (design clarification 5, corrected): a sub-pair closer than ξ at frame 0 that
/// is not adjacent keeps contact with the offset \f$\xi_p = (1 - m)\,d_0\f$, m = kInitialOffsetMargin,
/// raised to \f$\min(\xi, \max(\xi_p, (1 - m)\,d))\f$ at every later feasible distance d: toward ξ
/// as the pair separates, never lowered. The margin leaves the pair room to move. The simulation
/// (CollisionDetector) and the audit (PenetrationAudit) apply the same rule.
inline constexpr double kInitialOffsetMargin = 0.1;

/// Per-vertex neighbourhoods within a path-length radius along mesh edges (faces and strand
/// segments of one object; objects never connect). Built once from the rest (frame 0) positions;
/// immutable and safe for concurrent reads.
class TopologicalAdjacency {
 public:
  TopologicalAdjacency() = default;
  /// `rest`: #V positions giving the edge lengths; `radius`: the path-length bound (usually
  /// kAdjacencyRadiusInOffsets · ξ). A radius of 0 makes only identical vertices adjacent.
  TopologicalAdjacency(const Topology& topo, const Positions& rest, double radius);
  /// The same, with neighbourhoods only for the vertices marked in `sources` (#V, non-zero =
  /// source): vertices_adjacent(a, b) is then exact whenever a or b is a source.
  TopologicalAdjacency(const Topology& topo, const Positions& rest, double radius,
                       std::span<const std::uint8_t> sources);

  /// Whether a path of length ≤ radius joins a and b (always true for a == b).
  bool vertices_adjacent(Index a, Index b) const;
  /// Whether any vertex of `a` is adjacent to any vertex of `b`: the sub-pair of primitives with
  /// these vertex sets is topologically adjacent and may be excluded for the run.
  bool adjacent(std::span<const Index> a, std::span<const Index> b) const;

  double radius() const { return radius_; }
  /// Neighbours of v within the radius, sorted, v itself excluded.
  std::span<const Index> neighbours(Index v) const { return near_.row(v); }

 private:
  double radius_ = 0.0;
  Csr near_;
};

}  // namespace ccfr
