#pragma once
/// @file region.hpp
/// The convex collision-free region of each vertex (paper §3.1, Eq. 3) as a CSR set of half-spaces.
#include <cstdint>
#include <span>
#include <vector>

#include "ccfr/core/types.hpp"

namespace ccfr {

/// One half-space of a vertex's region, anchored at the vertex position `x` at detection time:
/// the vertex may move to `x'` iff \f$ (\mathbf{x}' - \mathbf{x})\cdot\mathbf{n} + d \ge 0 \f$.
/// `d` is the vertex's mass-weighted share of the gap (paper Alg. NarrowPhase, lines 10/26/41);
/// it is negative when the pair is already closer than the offset ξ (design clarification 7).
/// The generating pair's separation φ stays with its contact (ContactPair::distance - offset):
/// 32 bytes per plane, because dense scenes write millions of them per pass.
struct HalfSpace {
  Vec3 n = Vec3::UnitZ();  ///< unit normal pointing from the other primitive toward this vertex
  double d = 0.0;          ///< allowed advance along -n before the plane is reached

  /// Constraint value at `x_new` for anchor `x_anchor`: >= 0 means satisfied.
  double value(const Vec3& x_anchor, const Vec3& x_new) const { return (x_new - x_anchor).dot(n) + d; }
};

/// Per-vertex half-space sets in CSR form: vertex i owns planes[offsets[i], offsets[i+1]).
struct RegionSet {
  std::vector<Index> offsets{0};  ///< #V+1
  std::vector<HalfSpace> planes;  ///< all half-spaces, grouped by vertex

  Index num_vertices() const { return static_cast<Index>(offsets.size()) - 1; }
  Index count(Index v) const { return offsets[v + 1] - offsets[v]; }
  std::span<const HalfSpace> of(Index v) const { return {planes.data() + offsets[v], static_cast<size_t>(count(v))}; }
  size_t total() const { return planes.size(); }
  void clear(Index num_vertices);  ///< empty regions for `num_vertices` vertices
};

/// One half-space destined for `vertex`, tagged with a `key` that orders it within the vertex
/// (e.g. pair kind and primitive ids), so the final order does not depend on thread timing.
struct TaggedHalfSpace {
  Index vertex;
  std::uint64_t key;
  HalfSpace h;
};

/// Builds a RegionSet from per-thread (or per-chunk) buffers in two passes: count, prefix sum,
/// fill; then sorts each vertex's planes by key. Deterministic for any number of buffers.
void build_region_set(Index num_vertices, std::span<const std::vector<TaggedHalfSpace>> buffers, RegionSet& out);

}  // namespace ccfr
