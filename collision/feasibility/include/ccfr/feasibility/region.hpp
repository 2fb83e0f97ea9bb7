#pragma once
/// @file region.hpp
/// The convex collision-free region of each vertex (paper §3.1, Eq. 3): a CSR set of half-spaces
/// over one record per contact.
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

/// One contact's planes (paper Alg. NarrowPhase lines 10/26/41): side A's movable vertices get
/// \f$(\mathbf{n}, d_A)\f$, side B's \f$(-\mathbf{n}, d_B)\f$. 40 bytes per contact instead of 32 per
/// contact and vertex: the narrow phase writes millions per pass.
struct RegionRecord {
  Vec3 n = Vec3::UnitZ();    ///< unit normal from side B toward side A
  double d[2] = {0.0, 0.0};  ///< d_A, d_B
};

/// Per-vertex half-space sets in CSR form over shared per-contact records (the compact region,
/// issue 38): vertex v owns the planes at slots [row_start[v], row_start[v+1]); slot q is
/// `refs[q] = 2 · record + side`, the record's normal negated on side 1. A plane is built from
/// its record when read, with exactly the values a per-vertex copy would hold (negation is exact).
struct RegionSet {
  std::vector<Index> row_start{0};    ///< #V+1
  std::vector<RegionRecord> records;  ///< one per contact (or per plane, see add_plane)
  std::vector<std::uint32_t> refs;    ///< per slot: 2 · record + side, grouped by vertex

  Index num_vertices() const { return static_cast<Index>(row_start.size()) - 1; }
  Index count(Index v) const { return row_start[v + 1] - row_start[v]; }
  size_t total() const { return refs.size(); }
  /// The plane at slot q.
  HalfSpace plane(Index q) const { return plane_of_ref(refs[static_cast<size_t>(q)]); }
  HalfSpace plane_of_ref(std::uint32_t r) const {
    const RegionRecord& rec = records[r >> 1];
    return {(r & 1) ? Vec3(-rec.n) : rec.n, rec.d[r & 1]};
  }
  /// Vertex v's planes, gathered into `buf` (the projectors read contiguous planes).
  std::span<const HalfSpace> of(Index v, std::vector<HalfSpace>& buf) const;
  /// Vertex v's planes as a new vector (tests, diagnostics; allocates).
  std::vector<HalfSpace> of(Index v) const {
    std::vector<HalfSpace> buf;
    of(v, buf);
    return buf;
  }
  /// All planes in slot order (tests, benchmarks; allocates).
  std::vector<HalfSpace> rows() const;
  /// falls_below(x_anchor, x, planes of v, level) without the gather: the same values, the same answer.
  bool falls_below(Index v, const Vec3& x_anchor, const Vec3& x, double level) const;
  void clear(Index num_vertices);  ///< empty regions for `num_vertices` vertices

  /// Range over vertex v's planes by value, for `for (const HalfSpace& h : regions.planes_of(v))`.
  struct PlaneRange {
    const RegionSet* set;
    const std::uint32_t *first, *last;
    struct iterator {
      const RegionSet* set;
      const std::uint32_t* at;
      HalfSpace operator*() const { return set->plane_of_ref(*at); }
      iterator& operator++() {
        ++at;
        return *this;
      }
      bool operator!=(const iterator& o) const { return at != o.at; }
    };
    iterator begin() const { return {set, first}; }
    iterator end() const { return {set, last}; }
    size_t size() const { return static_cast<size_t>(last - first); }
  };
  PlaneRange planes_of(Index v) const {
    const std::uint32_t* base = refs.data();
    return {this, base + row_start[v], base + row_start[v + 1]};
  }
};

/// One half-space destined for `vertex`, tagged with a `key` that orders it within the vertex
/// (e.g. pair kind and primitive ids), so the final order does not depend on thread timing.
struct TaggedHalfSpace {
  Index vertex;
  std::uint64_t key;
  HalfSpace h;
};

/// Builds a RegionSet from per-thread (or per-chunk) buffers in two passes: count, prefix sum,
/// fill; then sorts each vertex's planes by key. Deterministic for any number of buffers. Each
/// plane gets its own record (no contact shares it).
void build_region_set(Index num_vertices, std::span<const std::vector<TaggedHalfSpace>> buffers, RegionSet& out);

}  // namespace ccfr
