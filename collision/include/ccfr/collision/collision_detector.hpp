#pragma once
/// @file collision_detector.hpp
/// Collision detection of CCFR (paper §3.1 and appendix, Alg. NarrowPhase): broad phase over
/// inflated primitive boxes, then closest points of every vertex-face, edge-edge, vertex-edge and
/// vertex-vertex sub-pair within the search range, each turned into one half-space per involved
/// vertex (Eq. 3) and one ContactPair for the contact response.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <memory>
#include <optional>
#include <span>
#include <string_view>
#include <utility>
#include <vector>

#include "ccfr/collision/broad_phase.hpp"
#include "ccfr/collision/primitives.hpp"
#include "ccfr/core/contact_model.hpp"
#include "ccfr/core/topology.hpp"
#include "ccfr/feasibility/region.hpp"
#include "ccfr/geometry/adjacency.hpp"

namespace ccfr {

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
  /// Mesh neighbours (closer than ξ at rest and topologically adjacent, offset fixed at 0.9 d₀):
  /// they keep their half-spaces but get no repulsion or friction, which would push a fine mesh's
  /// neighbours apart from their rest distance every substep. Beside `kind`, in its padding: 96
  /// bytes a contact instead of 104, for passes that hold tens of millions.
  bool neighbours = false;
  std::array<Index, 4> v{-1, -1, -1, -1};
  /// Barycentric weights, positive on side A and negative on side B, so that
  /// \f$ \sum_k w_k \mathbf{x}_{v_k} = \mathbf{x}_A - \mathbf{x}_B \f$ (closest points).
  std::array<double, 4> w{0, 0, 0, 0};
  Vec3 n = Vec3::UnitZ();  ///< unit normal from B to A at detection time
  double distance = 0.0;   ///< \f$ \|\mathbf{x}_A - \mathbf{x}_B\| \f$; φ = distance - offset
  /// This sub-pair's minimum separation: ξ, or a reduced offset for a pair that started closer
  /// than ξ (CollisionDetector, "initial proximity"); the pair must stay at least this far apart.
  double offset = 0.0;
  /// Vertices on side A (the first ones in v).
  int side_a() const { return kind == ContactKind::ee ? 2 : 1; }
  /// Vertices used in v.
  int size() const {
    return kind == ContactKind::vf || kind == ContactKind::ee ? 4 : (kind == ContactKind::ve ? 3 : 2);
  }
};
static_assert(sizeof(ContactPair) == 96, "ContactPair: kind and neighbours share the first word's padding");

/// A certified lower bound of the distance between the contact's two primitives at positions
/// `x`, from its detection normal: every point of side A lies at n·p >= min over A's vertices and
/// every point of side B at n·p <= max over B's vertices (the hulls' extremes along n are
/// vertices), so for unit n the primitives are at least the difference apart. Holds for any
/// direction, whatever moved since detection; the rounding of the dot products and of n's unit
/// length is subtracted (a few ulps of the coordinates' magnitude). NaN positions give NaN.
/// Where it already clears a threshold, the exact distance kernel need not run.
///
/// `scale` must be at least the largest |p|_1 of the contact's vertices: the rounding margin is
/// 64 ulps of it. The violation recount passes one value for the whole scene (its largest
/// |x|_1, computed once per recount) instead of taking the four vertices' own, which is looser
/// by a few ulps of the scene's extent and saves a third of the bound's work; inline for the same
/// reason (it runs for every contact after every resolution pass).
inline double separation_lower_bound(const ContactPair& c, const std::vector<Vec3>& x, double scale) {
  const int na = c.side_a(), n = c.size();
  double lo_a = std::numeric_limits<double>::infinity(), hi_b = -lo_a, sum = 0.0;
  for (int k = 0; k < n; ++k) {
    const double along = c.n.dot(x[static_cast<std::size_t>(c.v[k])]);
    sum += along;  // NaN if any is: std::min and std::max below would drop it
    if (k < na)
      lo_a = std::min(lo_a, along);
    else
      hi_b = std::max(hi_b, along);
  }
  // Each dot product is off by at most 3 eps sum|n_i p_i| <= 3 eps (1 + eps) |p|_1, the
  // difference by one more rounding, and |n| by a few ulps: 64 eps of margin covers all of it.
  constexpr double kEps = std::numeric_limits<double>::epsilon();
  const double gap = lo_a - hi_b;
  const double bound = (gap - 64.0 * kEps * (scale + std::abs(gap))) * (1.0 - 64.0 * kEps);
  return std::isnan(sum) ? sum : bound;
}
/// The same with the contact's own vertices' scale.
double separation_lower_bound(const ContactPair& c, const std::vector<Vec3>& x);

/// Counts and timings of one detect() pass.
struct DetectionStats {
  Index candidates = 0;          ///< primitive pairs reported by the broad phase
  Index pairs_within_range = 0;  ///< sub-pairs with φ < 2r, not excluded, with a movable vertex
  Index constraints = 0;         ///< half-spaces written to the RegionSet
  Index excluded_initial = 0;    ///< sub-pairs skipped by the initial-configuration exclusions (box within range)
  Index reduced_offset = 0;      ///< contacts whose offset is still below ξ (initial proximity)
  Index degenerate = 0;          ///< sub-pairs at (numerically) zero distance: no normal, no half-space
  bool reused = false;           ///< the pass evaluated the kept sub-pair list instead of the broad phase
  Index listed = 0;              ///< sub-pairs in the kept list after the pass (0: reuse off)
  double broad_s = 0.0;          ///< boxes + refit + pair query (a reused pass: the displacement check)
  double narrow_s = 0.0;         ///< closest points + half-spaces + RegionSet assembly
  double broad_serial_s = 0.0;   ///< the part of broad_s outside parallel loops (SerialStopwatch)
  double narrow_serial_s = 0.0;  ///< the part of narrow_s outside parallel loops
};

/// Key of a sub-pair, unique over all kinds: kind in bits 62-63, then the canonical ids (vf: vertex,
/// face; ee: lower, higher edge; ve: vertex, edge; vv: lower, higher vertex) in 31 bits each.
inline std::uint64_t sub_pair_key(ContactKind kind, Index a, Index b) {
  return (static_cast<std::uint64_t>(kind) << 62) | (static_cast<std::uint64_t>(a) << 31) |
         static_cast<std::uint64_t>(b);
}

/// How far a motion (x − ref per vertex) can have brought two primitives closer, as the kept
/// sub-pair list needs it (CollisionDetector::set_reuse_skin; docs/feasibility.md, "Reusing
/// detection"). The distance of two primitives does not change when both translate by the same t,
/// so for any t it drops by at most \f$\max_{a}|D_a - t| + \max_{b}|D_b - t|\f$ over the two sides'
/// vertices: a scene falling as a whole has moved nothing relative to itself. An object none of
/// whose vertices moved (an obstacle at rest) is *still*: against it a side has come closer by at
/// most \f$\max_b |D_b|\f$ (t = 0), its own vertices having stayed put.
struct ReuseMotion {
  /// t: the centre of the box of the moving objects' displacements, or 0 where that is no better.
  Vec3 shift = Vec3::Zero();
  double spread = 0.0;              ///< max |D_v − t| over the vertices of moving objects (infinity on NaN)
  double largest = 0.0;             ///< max |D_v| over the vertices of moving objects (infinity on NaN)
  std::vector<std::uint8_t> still;  ///< per object: every vertex has D = 0 exactly
};

/// Measures x − ref (#V each) per object of `topo`; writes |D_v − t| for every vertex to
/// `per_vertex` (#V) when given. Exact maxima and minima only, so the result does not depend on
/// the thread count.
ReuseMotion measure_reuse_motion(const Topology& topo, std::span<const Vec3> x, std::span<const Vec3> ref,
                                 double* per_vertex = nullptr);

/// What the initial configuration did to contact (counts of sub-pairs), for the log and run.json.
struct InitialProximity {
  /// Closer than ξ at rest and topologically adjacent: kept with the fixed offset (1 − m) d₀.
  Index adjacent_kept = 0;
  Index intersecting_pairs = 0;     ///< primitive pairs crossing each other (exact test)
  Index intersecting_excluded = 0;  ///< sub-pairs of those crossing pairs: excluded for the run
  Index reduced_offset = 0;         ///< closer than ξ, not adjacent: kept with a reduced offset
  double min_reduced_offset = 0.0;  ///< smallest initial reduced offset (0 if none)
  /// Shortest edge at rest over deformable objects (cloth, shell, tet, strand); infinity if none.
  double shortest_edge = 0.0;

  bool operator==(const InitialProximity&) const = default;
};

/// The planes of a contact whose gap the movable vertices cannot close by the usual split: a side
/// holding both movable and fixed (pinned, scripted, or fixed for this pass) vertices, or fixed
/// vertices on both sides, with \f$G = \varphi - K_A - K_B < 0\f$. Moving the free vertices along n
/// then leaves the fixed ones where they are, inside the offset (OGC's twisted square: a handle
/// vertex against the face of its own row's neighbours, folded along its diagonal). Sound rule:
/// with every fixed vertex at its known end position (x + kinematic_step) and every movable one
/// at x, pick a unit m (from B toward A) along which side A's fixed vertices end at least ξ beyond
/// side B's, then bound the movable ones so that all of A ends at m·p ≥ a and all of B at m·p ≤ b
/// with a − b ≥ ξ: the slab between keeps the two hulls ξ apart. m is the detection normal n if
/// that works, else the direction closest to n (bisection between n and the fixed vertices'
/// closest-point direction) that does. Returns the record {m, d_A, d_B}, or nothing when the
/// fixed vertices themselves end closer than the pair's offset (no plane can separate them).
std::optional<RegionRecord> mixed_pair_record(const ContactPair& c, const std::vector<Vec3>& x,
                                              std::span<const double> inv_mass, std::span<const Vec3> kinematic_step,
                                              double share_a);

/// Collision detection for one scene. Owns the primitive set, the broad phase and the exclusions
/// computed from the initial configuration; `topo` must outlive the detector.
///
/// Exclusions (design clarification 5; paper §4.1): sub-pairs whose primitives
/// share a vertex are never tested, and neither is any sub-pair of a primitive pair
/// (triangle-triangle, triangle-segment) that crosses in the initial configuration (exact
/// predicates). Every other sub-pair closer than ξ there keeps contact with a reduced offset
/// (1 − kInitialOffsetMargin) d₀: fixed for the run when it is topologically adjacent (a path of
/// length ≤ kAdjacencyRadiusInOffsets · ξ along the mesh edges joins them: a fine mesh's
/// neighbours), raised toward ξ as it separates otherwise. Triangles of one rigid or obstacle
/// object do not collide with each other.
class CollisionDetector {
 public:
  /// Builds the primitives and the broad phase at `initial` (#V) and records the exclusions
  /// (one spdlog info line with their counts). Throws ccfr::Error on non-finite positions.
  CollisionDetector(const Topology& topo, const Positions& initial, ContactModel params,
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
  /// the movable vertices is \f$G = \varphi - K_A - K_B\f$, with \f$K_B = \max(0, \max_j
  /// \mathbf{n}^\top\Delta\mathbf{x}_j)\f$ over side B's scripted vertices (and \f$K_A\f$ likewise along
  /// \f$-\mathbf{n}\f$), and each movable vertex gets \f$d = s\,G\f$ (Eq. 3 with a known, bounded
  /// \f$\Delta\mathbf{x}_B\f$). The worst vertex, not the closest point, because a rotating handle's far corner
  /// approaches faster. Valid while every kinematic step is at most r (the search range then still covers every pair
  /// that can come within ξ).
  ///
  /// Where that split cannot hold, a side that mixes movable and fixed vertices (or two sides that
  /// both hold fixed ones) in a pair whose G < 0, the pair's record comes from
  /// mixed_pair_record() instead.
  ///
  /// `vertex_reach` (#V, m, or empty for the uniform r): how far each vertex can move in the
  /// coming iteration (its step bound: at most r under contact.adaptive_reach, more in
  /// contact.momentum's last pass; a fixed vertex 0, a kinematic one its known step). A sub-pair is then in range
  /// within ρ_A + ρ_B + ξ, ρ a side's largest vertex reach, and the boxes grow by ρ + ξ/2 (no δ/2): a pair farther
  /// apart cannot come within ξ when every point of a primitive moves at most its vertices' largest step
  /// (docs/feasibility.md, "Adaptive reach"). The kept list (set_reuse_skin) is neither read nor built with it.
  void detect(const Positions& x, std::span<const double> inv_mass, RegionSet& regions,
              std::vector<ContactPair>& contacts, DetectionStats& stats, std::span<const Vec3> kinematic_step = {},
              std::span<const double> vertex_reach = {});

  /// Keeps the sub-pair list between passes (a Verlet list at the level of sub-pairs). A pass that
  /// runs the broad phase also lists every sub-pair within \f$2r + \xi + s\f$ (s = `skin`, m) that
  /// is not excluded and has a movable vertex. Later passes evaluate only the listed sub-pairs
  /// while the motion since listing (measure_reuse_motion) cannot have brought a sub-pair left out
  /// into the search range 2r + ξ: every vertex of a moving object within s/2 of its listing
  /// position shifted by one common t, and the moving objects within max(s, g − 2r − ξ) of
  /// their listing positions where g is their distance to the still objects (boxes at listing).
  /// Listed sub-pairs whose distance bound (listed distance less both sides' |D − t|) clears the
  /// range skip the kernel.
  /// The contacts, and so the regions, equal a fresh pass's exactly, in the same order (every
  /// broad phase reports its pairs in an order fixed by the tree or the ids, so a subsequence
  /// keeps it; a listing pass at a rebuild builds the tree over the boxes without the skin, then
  /// refits). A pass lists only when the previous pass's spread, repeated twice, keeps the list
  /// valid (4 spread < s), so that the list can be expected to serve at least twice: in fast
  /// scenes (each outer iteration moves vertices by up to r) the larger boxes would cost without
  /// reuses to pay for them.
  /// `skin` = 0 (the default) detects from scratch in every pass.
  void set_reuse_skin(double skin);
  double reuse_skin() const;
  /// Drops the kept list: the next pass runs the broad phase.
  void invalidate_reuse();
  /// Drops the kept list and the previous pass's positions, and takes `recent_step` (the spread of
  /// the last substep's displacements, e.g. ReuseMotion::spread of dt · v) as the motion that decides whether the
  /// next pass lists. Called at every frame start, it makes the reuse decisions depend only on
  /// state a checkpoint holds, so a resumed run reuses exactly where the uninterrupted one did.
  void restart_reuse(double recent_step);

  const ContactModel& params() const { return params_; }
  const CollisionPrimitives& primitives() const { return prims_; }
  const BroadPhase& broad_phase() const { return *broad_; }
  /// The primitive pairs of the last broad-phase query.
  const std::vector<IndexPair>& candidates() const { return candidates_; }
  /// Whether the sub-pair (canonical ids, see sub_pair_key) was excluded at construction.
  bool is_excluded(ContactKind kind, Index a, Index b) const;
  /// Excluded sub-pairs in total.
  Index num_excluded() const;
  /// Primitive pairs found intersecting in the initial configuration.
  Index num_initially_intersecting() const { return initial_proximity().intersecting_pairs; }
  /// The sub-pair's current offset: ξ, or its reduced offset while that is below ξ.
  double pair_offset(ContactKind kind, Index a, Index b) const;
  /// Counts of the initial configuration's exclusions and reduced offsets.
  const InitialProximity& initial_proximity() const;
  /// Sub-pairs whose offset is still below ξ.
  Index num_reduced_active() const;
  /// The current offset of every sub-pair that started closer than ξ, by slot: the detector's only
  /// state that changes during a run (checkpoints).
  const std::vector<double>& reduced_offsets() const;
  /// Restores reduced_offsets() saved from a detector built on the same initial configuration.
  /// Throws ccfr::Error when they cannot be: another count, a non-finite value, or an offset below
  /// its initial value or above ξ (offsets are only ever raised, up to ξ).
  void restore_reduced_offsets(std::span<const double> offsets);
  /// Remembers the reduced offsets as they are now (O(offsets still below ξ)) ...
  void mark_reduced_offsets();
  /// ... and puts them back: a substep solved again from its start must not keep the raises its
  /// abandoned solve made at positions the run never reached. No-op before any mark.
  void roll_back_reduced_offsets();

  /// Whether detect() also records, for every half-space it writes, the contact slot it came
  /// from (off by default; the contact response turns it on to skip indexing the contacts again).
  void set_record_plane_sources(bool on);
  /// The next pass rebuilds the broad phase over the current boxes instead of updating it. It
  /// also drops the kept list: a list enumerates in the order of the tree it was made with, and
  /// the passes after a rebuild must come out in the new tree's order, as fresh passes do.
  void rebuild_broad_phase();
  /// Per half-space of the last pass's RegionSet, in the same order: 4·c + k for contact c of the
  /// returned contacts and its vertex c.v[k]. A vertex's entries are in contact order. Empty
  /// unless set_record_plane_sources(true).
  std::span<const Index> plane_sources() const;

 private:
  /// The stages' state, defined in collision_detector.cpp: the initial pairs, the kept list and
  /// the assembly's buffers (collision/src).
  struct Stages;
  /// movable_[p]: primitive p has a vertex of inverse mass > 0; fixed_ = !movable_.
  void flag_movable_primitives(std::span<const double> inv_mass);
  /// Boxes at x (grown by s/2 when listing, by each vertex's reach when given), the tree updated or
  /// rebuilt, the candidates queried.
  void run_broad_phase(const Positions& x, bool listing, std::span<const double> vertex_reach);
  /// The candidates' contacts into `contacts`, in candidate order (and the list when listing).
  void enumerate_candidates(const Positions& x, std::span<const double> inv_mass, bool listing,
                            std::span<const double> vertex_reach, std::vector<ContactPair>& contacts,
                            DetectionStats& stats);
  /// Candidate chunks of about this many candidates, at least default_chunk_count's and at most
  /// kMostCandidateChunks of them.
  static constexpr Index kCandidatesPerChunk = 16384;
  static constexpr Index kMostCandidateChunks = 2048;

  const Topology& topo_;
  ContactModel params_;
  CollisionPrimitives prims_;
  std::unique_ptr<BroadPhase> broad_;
  std::unique_ptr<Stages> stages_;
  // Reused between passes to avoid reallocating millions of entries per outer iteration.
  std::vector<AABB> boxes_;
  std::vector<IndexPair> candidates_;
  std::vector<std::uint8_t> movable_;
  std::vector<std::uint8_t> fixed_;  ///< !movable_, handed to the broad phase
  bool rebuild_ = false;
};

}  // namespace ccfr
