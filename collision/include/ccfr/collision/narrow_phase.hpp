#pragma once
/// @file narrow_phase.hpp
/// Collision detection of CCFR (paper §3.1 and appendix, Alg. NarrowPhase): broad phase over
/// inflated primitive boxes, then closest points of every vertex-face, edge-edge, vertex-edge and
/// vertex-vertex sub-pair within the search range, each turned into one half-space per involved
/// vertex (Eq. 3) and one ContactPair for the contact response.
#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <string_view>
#include <vector>

#include "ccfr/collision/broad_phase.hpp"
#include "ccfr/collision/primitives.hpp"
#include "ccfr/core/scene.hpp"
#include "ccfr/feasibility/region.hpp"

namespace ccfr {

/// Distances of the contact model (paper notation).
struct CollisionParams {
  double radius = 0.005;            ///< r: search radius; pairs interact while φ < 2r
  double offset = 0.01;             ///< ξ: minimum separation (thickness)
  double repulsion_range = 0.0005;  ///< δ: repulsion band beyond ξ; only widens the boxes
};

/// The sub-pair kinds. The first-named primitive is side A of a ContactPair.
enum class ContactKind : std::uint8_t {
  vf = 0,  ///< vertex (A) - triangle (B); also the paper's face-vertex branch, seen from B
  ee = 1,  ///< edge (A, lower edge id) - edge (B)
  ve = 2,  ///< vertex (A, a point primitive) - strand segment (B)
  vv = 3,  ///< vertex (A, lower id) - vertex (B), both point primitives
};
std::string_view to_string(ContactKind kind);

/// One sub-pair within the search range, for the contact response (repulsion, friction,
/// post_process). Unused slots have v = -1 and w = 0: vf uses 1 + 3 vertices, ee 2 + 2, ve 1 + 2,
/// vv 1 + 1.
struct ContactPair {
  ContactKind kind = ContactKind::vf;
  std::array<Index, 4> v{-1, -1, -1, -1};
  /// Barycentric weights, positive on side A and negative on side B, so that
  /// \f$ \sum_k w_k \mathbf{x}_{v_k} = \mathbf{x}_A - \mathbf{x}_B \f$ (closest points).
  std::array<double, 4> w{0, 0, 0, 0};
  Vec3 n = Vec3::UnitZ();  ///< unit normal from B to A at detection time
  double distance = 0.0;   ///< \f$ \|\mathbf{x}_A - \mathbf{x}_B\| \f$; φ = distance - ξ
  /// Vertices on side A (the first ones in v).
  int side_a() const { return kind == ContactKind::ee ? 2 : 1; }
  /// Vertices used in v.
  int size() const { return kind == ContactKind::vf || kind == ContactKind::ee ? 4 : (kind == ContactKind::ve ? 3 : 2); }
};

/// Counts and timings of one detect() pass.
struct DetectionStats {
  Index candidates = 0;          ///< primitive pairs reported by the broad phase
  Index pairs_within_range = 0;  ///< sub-pairs with φ < 2r, not excluded, with a movable vertex
  Index constraints = 0;         ///< half-spaces written to the RegionSet
  Index excluded_initial = 0;    ///< sub-pairs skipped by the initial-configuration exclusions (box within range)
  Index degenerate = 0;          ///< sub-pairs at (numerically) zero distance: no normal, no half-space
  double broad_s = 0.0;          ///< boxes + refit + pair query
  double narrow_s = 0.0;         ///< closest points + half-spaces + RegionSet assembly
};

/// Key of a sub-pair, unique over all kinds: kind in bits 62-63, then the canonical ids (vf: vertex,
/// face; ee: lower, higher edge; ve: vertex, edge; vv: lower, higher vertex) in 31 bits each.
inline std::uint64_t sub_pair_key(ContactKind kind, Index a, Index b) {
  return (static_cast<std::uint64_t>(kind) << 62) | (static_cast<std::uint64_t>(a) << 31) | static_cast<std::uint64_t>(b);
}

namespace detail {
/// An immutable set of sub-pairs, one CSR per kind (row = first canonical id, sorted second
/// ids): a lookup touches one short contiguous row, which keeps the millions of lookups of a
/// fine cloth in cache far better than a hash table over 64-bit keys. Safe for concurrent reads.
class ExclusionSet {
 public:
  /// Replaces the set by `keys` (sub_pair_key values; duplicates allowed).
  void assign(std::vector<std::uint64_t> keys);
  /// Inline: the narrow phase looks up millions of sub-pairs per pass. Rows are short (the
  /// sub-pairs closer than ξ around one vertex or edge), so a linear scan of the sorted row beats
  /// a binary search up to a few dozen entries.
  bool contains(ContactKind kind, Index a, Index b) const {
    const Rows& r = rows_[static_cast<size_t>(kind)];
    if (a + 1 >= static_cast<Index>(r.offsets.size())) return false;
    const Index* first = r.cols.data() + r.offsets[a];
    const Index* last = r.cols.data() + r.offsets[a + 1];
    if (last - first > kLinearScan) return std::binary_search(first, last, b);
    for (; first != last && *first < b; ++first) {
    }
    return first != last && *first == b;
  }
  size_t size() const { return size_; }

 private:
  struct Rows {
    std::vector<Index> offsets, cols;
  };
  static constexpr std::ptrdiff_t kLinearScan = 32;
  std::array<Rows, 4> rows_;
  size_t size_ = 0;
};
}  // namespace detail

/// Collision detection for one scene. Owns the primitive set, the broad phase and the exclusions
/// computed from the initial configuration; `topo` must outlive the detector.
///
/// Exclusions (design clarification 5; paper §4.1): sub-pairs whose primitives share a vertex are
/// never tested; sub-pairs closer than ξ in the initial configuration, and every sub-pair of a
/// primitive pair (triangle-triangle, triangle-segment) that intersects in the initial
/// configuration, are excluded for the whole run. Triangles of one rigid or obstacle object do
/// not collide with each other.
class CollisionDetector {
 public:
  /// Builds the primitives and the broad phase at `initial` (#V) and records the exclusions
  /// (one spdlog info line with their counts). Throws ccfr::Error on non-finite positions.
  CollisionDetector(const Topology& topo, const Positions& initial, CollisionParams params,
                    std::unique_ptr<BroadPhase> broad_phase);
  ~CollisionDetector();
  CollisionDetector(const CollisionDetector&) = delete;
  CollisionDetector& operator=(const CollisionDetector&) = delete;

  /// Broad and narrow phase at positions `x` (#V, the regions' anchors) with inverse masses
  /// `inv_mass` (#V; 0 = kinematic or pinned). Fills `regions` with every vertex's half-spaces
  /// (Alg. NarrowPhase lines 10, 26, 41; Eq. 3) and `contacts` with every sub-pair within range
  /// that has a movable vertex; overwrites `stats`. Vertices of inverse mass 0 get no half-spaces
  /// (the solver does not move them; their side's share is 0). Deterministic for any thread count.
  ///
  /// `kinematic_step` (#V, or empty): the known displacement of kinematic vertices during the
  /// coming iteration. A kinematic side's motion is not bounded by a share, it is known: every
  /// vertex of a side must stay behind the plane through its closest point, so the gap left to
  /// the movable vertices is \f$G = \varphi - K_A - K_B\f$, with \f$K_B = \max(0, \max_j \mathbf{n}^\top\Delta\mathbf{x}_j)\f$
  /// over side B's scripted vertices (and \f$K_A\f$ likewise along \f$-\mathbf{n}\f$), and each
  /// movable vertex gets \f$d = s\,G\f$ (Eq. 3 with a known, bounded \f$\Delta\mathbf{x}_B\f$). The worst
  /// vertex, not the closest point, because a rotating handle's far corner approaches faster.
  /// Valid while every kinematic step is at most r (the search range then still covers every
  /// pair that can come within ξ).
  void detect(const Positions& x, std::span<const double> inv_mass, RegionSet& regions,
              std::vector<ContactPair>& contacts, DetectionStats& stats, std::span<const Vec3> kinematic_step = {});

  const CollisionParams& params() const { return params_; }
  const CollisionPrimitives& primitives() const { return prims_; }
  const BroadPhase& broad_phase() const { return *broad_; }
  /// The primitive pairs of the last broad-phase query.
  const std::vector<IndexPair>& candidates() const { return candidates_; }
  /// Whether the sub-pair (canonical ids, see sub_pair_key) was excluded at construction.
  bool is_excluded(ContactKind kind, Index a, Index b) const { return excluded_.contains(kind, a, b); }
  /// Excluded sub-pairs in total.
  Index num_excluded() const { return static_cast<Index>(excluded_.size()); }
  /// Primitive pairs found intersecting in the initial configuration.
  Index num_initially_intersecting() const { return initially_intersecting_; }

 private:
  void compute_exclusions(const Positions& initial);
  void assemble(std::span<const double> inv_mass, std::span<const Vec3> kinematic_step, std::vector<ContactPair>& contacts,
                RegionSet& regions);

  const Topology& topo_;
  CollisionParams params_;
  CollisionPrimitives prims_;
  std::unique_ptr<BroadPhase> broad_;
  detail::ExclusionSet excluded_;
  Index initially_intersecting_ = 0;
  // Reused between passes to avoid reallocating millions of entries per outer iteration.
  std::vector<AABB> boxes_;
  std::vector<IndexPair> candidates_;
  std::vector<std::uint8_t> movable_;
  std::vector<std::vector<ContactPair>> contact_buffers_;
  std::vector<Index> block_cursor_;  ///< #blocks by #V plane counts, then write cursors
};

}  // namespace ccfr
