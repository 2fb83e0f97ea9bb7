#include "ccfr/collision/collision_detector.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>

#include "ccfr/core/block_cursors.hpp"
#include "ccfr/core/error.hpp"
#include "ccfr/core/log.hpp"
#include "ccfr/core/parallel.hpp"
#include "ccfr/core/timer.hpp"
#include "ccfr/geometry/adjacency.hpp"
#include "ccfr/geometry/distance.hpp"
#include "ccfr/geometry_exact/predicates.hpp"

namespace ccfr {

std::string_view to_string(ContactKind kind) {
  switch (kind) {
    case ContactKind::vf:
      return "vf";
    case ContactKind::ee:
      return "ee";
    case ContactKind::ve:
      return "ve";
    case ContactKind::vv:
      return "vv";
  }
  return "unknown";
}

namespace detail {

void InitialPairTable::assign(std::vector<std::pair<std::uint64_t, Index>> entries) {
  std::sort(entries.begin(), entries.end());  // by key, then smallest slot first (kExcluded < 0)
  entries.erase(
      std::unique(entries.begin(), entries.end(), [](const auto& x, const auto& y) { return x.first == y.first; }),
      entries.end());
  size_ = entries.size();
  excluded_ = 0;
  constexpr std::uint64_t kMask = (std::uint64_t{1} << 31) - 1;
  for (auto& r : rows_) {
    r.row_start.assign(1, 0);
    r.cols.clear();
    r.slots.clear();
  }
  // Sorted keys are grouped by kind, then by first id, then by second id.
  for (const auto& [k, slot] : entries) {
    Rows& r = rows_[k >> 62];
    const Index a = static_cast<Index>((k >> 31) & kMask), b = static_cast<Index>(k & kMask);
    while (static_cast<Index>(r.row_start.size()) <= a + 1) r.row_start.push_back(static_cast<Index>(r.cols.size()));
    r.cols.push_back(b);
    r.slots.push_back(slot);
    r.row_start.back() = static_cast<Index>(r.cols.size());
    excluded_ += slot == kExcluded;
  }
}

ListedSubPair ListedSubPair::make(ContactKind kind, Index a, Index b, Index slot, double dist_sq) {
  const double d = std::sqrt(dist_sq);
  float f = static_cast<float>(d);
  if (static_cast<double>(f) > d) f = std::nextafter(f, 0.0f);  // a lower bound, never above d
  return {a, b, slot, kind, f};
}

}  // namespace detail

namespace {

/// Below this distance (m) the closest points coincide numerically: the pair touches or
/// intersects and has no usable normal.
constexpr double kMinNormalDistance = 1e-12;

bool has_vertex(const Vec3i& f, Index v) { return f[0] == v || f[1] == v || f[2] == v; }
bool share_vertex(const Vec2i& a, const Vec2i& b) {
  return a[0] == b[0] || a[0] == b[1] || a[1] == b[0] || a[1] == b[1];
}

/// Calls the sink once for every sub-pair of the primitive pair (p, q) that its
/// representatives assign to this pair (Curtis et al. 2008): a triangle tests only the vertices
/// and edges it represents, so over all triangle pairs each vertex-face and edge-edge sub-pair
/// comes up exactly once. Sub-pairs sharing a vertex are skipped here; so are pairs of triangles of
/// one rigid or obstacle object.
template <class Sink>
void visit_sub_pairs(const Topology& topo, const CollisionPrimitives& prims, Index p, Index q, Sink& sink) {
  PrimitiveKind kp = prims.kind(p), kq = prims.kind(q);
  if (kp > kq) {
    std::swap(p, q);
    std::swap(kp, kq);
  }
  const Index a = prims.element(p), b = prims.element(q);
  if (kp == PrimitiveKind::triangle) {
    const Vec3i& fa = topo.faces[a];
    const std::uint8_t own_a = prims.face_owns[a];
    if (kq == PrimitiveKind::triangle) {
      if (prims.face_no_self[a] && topo.face_object[a] == topo.face_object[b]) return;
      const Vec3i& fb = topo.faces[b];
      const std::uint8_t own_b = prims.face_owns[b];
      for (int k = 0; k < 3; ++k)
        if ((own_a >> k & 1) && !has_vertex(fb, fa[k])) sink.vf(fa[k], b);
      for (int k = 0; k < 3; ++k)
        if ((own_b >> k & 1) && !has_vertex(fa, fb[k])) sink.vf(fb[k], a);
      for (int k = 0; k < 3; ++k) {
        if (!(own_a >> (3 + k) & 1)) continue;
        const Index ea = topo.face_edges[a][k];
        for (int l = 0; l < 3; ++l) {
          if (!(own_b >> (3 + l) & 1)) continue;
          const Index eb = topo.face_edges[b][l];
          if (!share_vertex(topo.edges[ea], topo.edges[eb])) sink.ee(ea, eb);
        }
      }
    } else if (kq == PrimitiveKind::edge) {
      const Vec2i& seg = topo.edges[b];
      const std::uint8_t own_s = prims.segment_owns[static_cast<size_t>(q - prims.num_triangles)];
      for (int k = 0; k < 2; ++k)
        if ((own_s >> k & 1) && !has_vertex(fa, seg[k])) sink.vf(seg[k], a);
      for (int k = 0; k < 3; ++k) {
        if (!(own_a >> (3 + k) & 1)) continue;
        const Index ea = topo.face_edges[a][k];
        if (!share_vertex(topo.edges[ea], seg)) sink.ee(ea, b);
      }
    } else {
      if (!has_vertex(fa, b)) sink.vf(b, a);
    }
  } else if (kp == PrimitiveKind::edge) {
    if (kq == PrimitiveKind::edge) {
      if (!share_vertex(topo.edges[a], topo.edges[b])) sink.ee(a, b);
    } else {
      if (topo.edges[a][0] != b && topo.edges[a][1] != b) sink.ve(b, a);
    }
  } else {
    sink.vv(a, b);
  }
}

/// Closest points of one sub-pair: side A and side B vertices with barycentric weights.
struct Closest {
  ContactKind kind;
  Index id_a, id_b;  ///< canonical ids of the sub-pair (see sub_pair_key)
  int na, nb;
  Index va[2], vb[3];
  double wa[2], wb[3];
  Vec3 pa, pb;
  double dist_sq;
};

bool boxes_within(const Vec3& alo, const Vec3& ahi, const Vec3& blo, const Vec3& bhi, double reach) {
  return (alo.array() <= bhi.array() + reach).all() && (blo.array() <= ahi.array() + reach).all();
}

/// Computes the closest points of sub-pairs in canonical orientation (so the result does not
/// depend on which primitive of the pair came first), after a box pre-check against `reach`.
/// Returns false when the sub-pair is certainly farther than `reach`. Used for the exclusions of
/// the initial configuration; the detection pass has its own inlined variant (DetectSink).
struct ClosestPoints {
  const Topology& topo;
  const Positions& x;
  double reach;

  bool vf(Index v, Index f, Closest& c) const {
    const Vec3& p = x[v];
    const Vec3i& t = topo.faces[f];
    const Vec3 &a = x[t[0]], &b = x[t[1]], &d = x[t[2]];
    const Vec3 lo = a.cwiseMin(b).cwiseMin(d), hi = a.cwiseMax(b).cwiseMax(d);
    if (!boxes_within(p, p, lo, hi, reach)) return false;
    const PointTriangleResult r = point_triangle(p, a, b, d);
    c = {ContactKind::vf,
         v,
         f,
         1,
         3,
         {v, -1},
         {t[0], t[1], t[2]},
         {1.0, 0.0},
         {r.bary[0], r.bary[1], r.bary[2]},
         p,
         r.closest,
         r.distance_sq};
    return true;
  }
  bool ee(Index e0, Index e1, Closest& c) const {
    if (e0 > e1) std::swap(e0, e1);
    const Vec2i &ea = topo.edges[e0], &eb = topo.edges[e1];
    const Vec3 &a0 = x[ea[0]], &a1 = x[ea[1]], &b0 = x[eb[0]], &b1 = x[eb[1]];
    if (!boxes_within(a0.cwiseMin(a1), a0.cwiseMax(a1), b0.cwiseMin(b1), b0.cwiseMax(b1), reach)) return false;
    const EdgeEdgeResult r = edge_edge(a0, a1, b0, b1);
    c = {ContactKind::ee,
         e0,
         e1,
         2,
         2,
         {ea[0], ea[1]},
         {eb[0], eb[1], -1},
         {1.0 - r.s, r.s},
         {1.0 - r.t, r.t, 0.0},
         r.pa,
         r.pb,
         r.distance_sq};
    return true;
  }
  bool ve(Index v, Index e, Closest& c) const {
    const Vec3& p = x[v];
    const Vec2i& s = topo.edges[e];
    const Vec3 &a = x[s[0]], &b = x[s[1]];
    if (!boxes_within(p, p, a.cwiseMin(b), a.cwiseMax(b), reach)) return false;
    const PointEdgeResult r = point_edge(p, a, b);
    c = {ContactKind::ve, v, e, 1, 2, {v, -1}, {s[0], s[1], -1}, {1.0, 0.0}, {1.0 - r.t, r.t, 0.0}, p, r.closest,
         r.distance_sq};
    return true;
  }
  bool vv(Index v0, Index v1, Closest& c) const {
    if (v0 > v1) std::swap(v0, v1);
    const Vec3 &p = x[v0], &q = x[v1];
    if (!boxes_within(p, p, q, q, reach)) return false;
    c = {ContactKind::vv,
         v0,
         v1,
         1,
         1,
         {v0, -1},
         {v1, -1, -1},
         {1.0, 0.0},
         {1.0, 0.0, 0.0},
         p,
         q,
         point_point_distance_sq(p, q)};
    return true;
  }
};

/// Sink of the detection pass: records each sub-pair within range as a contact; the
/// half-spaces are derived from the contacts afterwards (assemble).
///
/// Same tests in the same order as ClosestPoints followed by the range check (box pre-check,
/// exclusion look-up, distance kernel, φ < 2r, movable vertex), but written per kind so that
/// everything except the distance kernels inlines into the candidate loop and the contact is
/// built in place, without the intermediate Closest record: this bookkeeping cost more
/// instructions than the kernels themselves.
struct DetectSink {
  const Topology& topo;
  const Positions& x;
  std::span<const double> w;
  const detail::InitialPairTable& table;
  const std::vector<double>& reduced;  ///< current offset per reduced slot
  double xi;
  double reach, reach_sq;
  std::vector<ContactPair>& contacts;
  /// When building the reusable list (CollisionDetector::set_reuse_skin): every sub-pair within
  /// `list_reach` that has a movable vertex goes there, and the pre-filters use `list_reach`.
  std::vector<detail::ListedSubPair>* list = nullptr;
  double list_reach = 0.0, list_reach_sq = 0.0;
  Index within = 0, degenerate = 0, excluded = 0, reduced_contacts = 0;
  const std::uint8_t* fixed = nullptr;  ///< per reduced slot: mesh neighbours (CollisionDetector::reduced_fixed_)

  /// Adds this sink's counters to a pass's statistics.
  void add_to(DetectionStats& stats) const {
    stats.pairs_within_range += within;
    stats.excluded_initial += excluded;
    stats.degenerate += degenerate;
    stats.reduced_offset += reduced_contacts;
  }

  /// Reach of the conservative pre-filters: the list's when building it, else the contacts'.
  double filter_reach() const { return list ? list_reach : reach; }
  double filter_reach_sq() const { return list ? list_reach_sq : reach_sq; }
  /// The sub-pair's reduced-offset slot, kAbsent for ξ, or kExcluded (counted) when it is excluded.
  Index slot_of(ContactKind kind, Index a, Index b) {
    const Index slot = table.find(kind, a, b);
    if (slot == detail::InitialPairTable::kExcluded) ++excluded;
    return slot;
  }
  double offset_at(Index slot) const { return slot >= 0 ? reduced[static_cast<size_t>(slot)] : xi; }
  /// Alg. NarrowPhase lines 7/22/38: φ = ‖x_A − x_B‖ − ξ < 2r  ⇔  ‖x_A − x_B‖ < 2r + ξ; then
  /// the movable check and the degenerate-distance check. Returns the distance, or a negative
  /// value when the sub-pair yields no contact. A reduced offset only shrinks the range, so the
  /// reach of ξ is conservative for it. Lists the sub-pair first when a list is being built.
  double accept(ContactKind kind, Index a, Index b, Index slot, double dist_sq, bool movable) {
    if (!movable) return -1.0;  // nothing here can move: nothing to constrain
    if (list && dist_sq < list_reach_sq) list->push_back(detail::ListedSubPair::make(kind, a, b, slot, dist_sq));
    if (dist_sq >= reach_sq) return -1.0;
    ++within;
    const double dist = std::sqrt(dist_sq);
    if (dist < kMinNormalDistance) {
      ++degenerate;
      return -1.0;
    }
    return dist;
  }
  /// Whether the slot is a mesh neighbours' fixed offset (reduced_fixed_).
  bool fixed_at(Index slot) const { return slot >= 0 && fixed && fixed[slot]; }
  void emit(ContactKind kind, const std::array<Index, 4>& v, const std::array<double, 4>& wts, const Vec3& pa,
            const Vec3& pb, double dist, double offset, bool neighbours) {
    // Built whole in place: a default-constructed record overwritten field by field cost a
    // second write of its 96 bytes.
    contacts.push_back(
        ContactPair{kind, v, wts, (pa - pb) / dist, dist, offset, neighbours});  // lines 9/25/40: n from B to A
    reduced_contacts += offset < xi;
  }

  // Pre-filters (box test, exclusions), then the *_eval kernels, which a reused pass calls directly.
  void vf(Index v, Index f) {
    const Vec3& p = x[v];
    const Vec3i& t = topo.faces[f];
    const Vec3 &a = x[t[0]], &b = x[t[1]], &d = x[t[2]];
    const Vec3 lo = a.cwiseMin(b).cwiseMin(d), hi = a.cwiseMax(b).cwiseMax(d);
    if (!boxes_within(p, p, lo, hi, filter_reach())) return;
    const Index slot = slot_of(ContactKind::vf, v, f);
    if (slot != detail::InitialPairTable::kExcluded) vf_eval(v, f, slot);
  }
  void vf_eval(Index v, Index f, Index slot) {
    const Vec3& p = x[v];
    const Vec3i& t = topo.faces[f];
    if (point_triangle_apart_along_centres(p, x[t[0]], x[t[1]], x[t[2]], filter_reach_sq())) return;
    const PointTriangleResult r = point_triangle(p, x[t[0]], x[t[1]], x[t[2]]);
    const double dist = accept(ContactKind::vf, v, f, slot, r.distance_sq,
                               w[v] > 0.0 || w[t[0]] > 0.0 || w[t[1]] > 0.0 || w[t[2]] > 0.0);
    if (dist < 0.0) return;
    emit(ContactKind::vf, {v, t[0], t[1], t[2]}, {1.0, -r.bary[0], -r.bary[1], -r.bary[2]}, p, r.closest, dist,
         offset_at(slot), fixed_at(slot));
  }
  void ee(Index e0, Index e1) {
    if (e0 > e1) std::swap(e0, e1);
    const Vec2i &ea = topo.edges[e0], &eb = topo.edges[e1];
    const Vec3 &a0 = x[ea[0]], &a1 = x[ea[1]], &b0 = x[eb[0]], &b1 = x[eb[1]];
    if (!boxes_within(a0.cwiseMin(a1), a0.cwiseMax(a1), b0.cwiseMin(b1), b0.cwiseMax(b1), filter_reach())) return;
    const Index slot = slot_of(ContactKind::ee, e0, e1);
    if (slot != detail::InitialPairTable::kExcluded) ee_eval(e0, e1, slot);
  }
  void ee_eval(Index e0, Index e1, Index slot) {
    const Vec2i &ea = topo.edges[e0], &eb = topo.edges[e1];
    const Vec3 &a0 = x[ea[0]], &a1 = x[ea[1]], &b0 = x[eb[0]], &b1 = x[eb[1]];
    // Two separating-axis bounds before the kernel; accept() would refuse what they settle.
    if (segments_apart_along_centres(a0, a1, b0, b1, filter_reach_sq())) return;
    if (segments_certainly_apart(a0, a1, b0, b1, filter_reach_sq())) return;
    const EdgeEdgeResult r = edge_edge(a0, a1, b0, b1);
    const double dist = accept(ContactKind::ee, e0, e1, slot, r.distance_sq,
                               w[ea[0]] > 0.0 || w[ea[1]] > 0.0 || w[eb[0]] > 0.0 || w[eb[1]] > 0.0);
    if (dist < 0.0) return;
    emit(ContactKind::ee, {ea[0], ea[1], eb[0], eb[1]}, {1.0 - r.s, r.s, -(1.0 - r.t), -r.t}, r.pa, r.pb, dist,
         offset_at(slot), fixed_at(slot));
  }
  void ve(Index v, Index e) {
    const Vec3& p = x[v];
    const Vec2i& s = topo.edges[e];
    const Vec3 &a = x[s[0]], &b = x[s[1]];
    if (!boxes_within(p, p, a.cwiseMin(b), a.cwiseMax(b), filter_reach())) return;
    const Index slot = slot_of(ContactKind::ve, v, e);
    if (slot != detail::InitialPairTable::kExcluded) ve_eval(v, e, slot);
  }
  void ve_eval(Index v, Index e, Index slot) {
    const Vec3& p = x[v];
    const Vec2i& s = topo.edges[e];
    if (point_segment_apart_along_centres(p, x[s[0]], x[s[1]], filter_reach_sq())) return;
    const PointEdgeResult r = point_edge(p, x[s[0]], x[s[1]]);
    const double dist =
        accept(ContactKind::ve, v, e, slot, r.distance_sq, w[v] > 0.0 || w[s[0]] > 0.0 || w[s[1]] > 0.0);
    if (dist < 0.0) return;
    emit(ContactKind::ve, {v, s[0], s[1], -1}, {1.0, -(1.0 - r.t), -r.t, 0.0}, p, r.closest, dist, offset_at(slot),
         fixed_at(slot));
  }
  void vv(Index v0, Index v1) {
    if (v0 > v1) std::swap(v0, v1);
    const Vec3 &p = x[v0], &q = x[v1];
    if (!boxes_within(p, p, q, q, filter_reach())) return;
    const Index slot = slot_of(ContactKind::vv, v0, v1);
    if (slot != detail::InitialPairTable::kExcluded) vv_eval(v0, v1, slot);
  }
  void vv_eval(Index v0, Index v1, Index slot) {
    const Vec3 &p = x[v0], &q = x[v1];
    const double dist =
        accept(ContactKind::vv, v0, v1, slot, point_point_distance_sq(p, q), w[v0] > 0.0 || w[v1] > 0.0);
    if (dist < 0.0) return;
    emit(ContactKind::vv, {v0, v1, -1, -1}, {1.0, -1.0, 0.0, 0.0}, p, q, dist, offset_at(slot), fixed_at(slot));
  }
};

/// Sums the sub-pair counters of one chunk's pass into the pass's statistics.
void add_counts(DetectionStats& total, const DetectionStats& part) {
  total.pairs_within_range += part.pairs_within_range;
  total.excluded_initial += part.excluded_initial;
  total.degenerate += part.degenerate;
  total.reduced_offset += part.reduced_offset;
}

/// Share of side A of a contact's gap (design clarification 4): \f$ s_A = w_A / (w_A + w_B) \f$
/// with \f$ w_{side} = \sum_i \beta_i w_i \f$ (Alg. NarrowPhase lines 8, 23-24), so s_A + s_B = 1.
/// Then for displacements inside all half-spaces every vertex of A stays at
/// n·x ≥ n·x_A − s_A φ and every vertex of B at n·x ≤ n·x_B + s_B φ (the closest points are
/// extreme along n over each primitive): the plane in between keeps the primitives
/// ≥ ‖x_A − x_B‖ − φ = ξ apart. Any split summing to 1 keeps this argument.
///
/// Where immovable vertices hold part β_fixed of a side's closest point, that part counts with
/// the mean inverse mass of the side's movable vertices:
/// \f$ w_{side} = \sum_{i\,\mathrm{movable}} \beta_i w_i + \beta_{fixed}\,\bar w_{movable} \f$.
/// The side can still turn about its pinned point; with the paper's weights alone a cloth vertex
/// next to a handle vertex at the closest point got s = 0, no room in any such pair, and its
/// cone of zero-room planes held it at its anchor for good while its cloth moved on (OGC's
/// twisted square: one vertex held for 8 frames, its edges stretched 8x, then a squeeze). A side
/// without immovable vertices keeps the paper's weight; both closest points on immovable vertices
/// split the gap by the sides' movable means (½–½ for equal masses), where emitting nothing would
/// let a free vertex swing its edge or face through the pair.
double share_a(const ContactPair& c, std::span<const double> w) {
  // Σ β_i w_i over a side, its fixed part weighted by the movable mean: > 0 iff a vertex moves.
  auto side = [&](int lo, int hi) {
    double weighted = 0.0, fixed_beta = 0.0, movable_sum = 0.0;
    int movable = 0;
    for (int k = lo; k < hi; ++k) {
      const double beta = std::abs(c.w[k]), wk = w[c.v[k]];
      if (wk > 0.0) {
        weighted += beta * wk;
        movable_sum += wk;
        ++movable;
      } else {
        fixed_beta += beta;
      }
    }
    return movable > 0 ? weighted + fixed_beta * (movable_sum / movable) : 0.0;
  };
  const int na = c.side_a();
  const double w_a = side(0, na), w_b = side(na, c.size());
  return w_a + w_b > 0.0 ? w_a / (w_a + w_b) : 0.0;  // 0: no movable vertex (such pairs are skipped)
}

/// A sub-pair closer than ξ in the initial configuration (clarification 5).
struct CloseSubPair {
  std::uint64_t key;
  double distance;
  std::array<Index, 2> va;  ///< side A's vertices (-1 unused)
  std::array<Index, 3> vb;  ///< side B's vertices (-1 unused)
};

/// Sink of the initial pass: collects sub-pairs closer than ξ with their distances and vertices.
struct CloserThanOffsetSink {
  ClosestPoints cp;  // reach = ξ
  std::vector<CloseSubPair>& out;

  void vf(Index v, Index f) { run(&ClosestPoints::vf, v, f); }
  void ee(Index a, Index b) { run(&ClosestPoints::ee, a, b); }
  void ve(Index v, Index e) { run(&ClosestPoints::ve, v, e); }
  void vv(Index a, Index b) { run(&ClosestPoints::vv, a, b); }
  template <class Fn>
  void run(Fn fn, Index a, Index b) {
    Closest c;
    if (!(cp.*fn)(a, b, c) || !(c.dist_sq < cp.reach * cp.reach)) return;
    CloseSubPair& s = out.emplace_back();
    s.key = sub_pair_key(c.kind, c.id_a, c.id_b);
    s.distance = std::sqrt(c.dist_sq);
    s.va = {c.va[0], c.na > 1 ? c.va[1] : -1};
    s.vb = {c.vb[0], c.nb > 1 ? c.vb[1] : -1, c.nb > 2 ? c.vb[2] : -1};
  }
};

/// Sink that records every sub-pair it is given (all of them, not only the represented ones).
struct AllKeysSink {
  std::vector<std::uint64_t>& keys;
  void vf(Index v, Index f) { keys.push_back(sub_pair_key(ContactKind::vf, v, f)); }
  void ee(Index a, Index b) { keys.push_back(sub_pair_key(ContactKind::ee, std::min(a, b), std::max(a, b))); }
  void ve(Index v, Index e) { keys.push_back(sub_pair_key(ContactKind::ve, v, e)); }
  void vv(Index a, Index b) { keys.push_back(sub_pair_key(ContactKind::vv, std::min(a, b), std::max(a, b))); }
};

/// Squared distance of a sub-pair given by its key at positions x.
double key_distance_sq(const Topology& topo, const Positions& x, std::uint64_t key) {
  constexpr std::uint64_t kMask = (std::uint64_t{1} << 31) - 1;
  const auto kind = static_cast<ContactKind>(key >> 62);
  const Index a = static_cast<Index>((key >> 31) & kMask), b = static_cast<Index>(key & kMask);
  switch (kind) {
    case ContactKind::vf: {
      const Vec3i& f = topo.faces[b];
      return point_triangle(x[a], x[f[0]], x[f[1]], x[f[2]]).distance_sq;
    }
    case ContactKind::ee: {
      const Vec2i &e = topo.edges[a], &g = topo.edges[b];
      return edge_edge(x[e[0]], x[e[1]], x[g[0]], x[g[1]]).distance_sq;
    }
    case ContactKind::ve: {
      const Vec2i& e = topo.edges[b];
      return point_edge(x[a], x[e[0]], x[e[1]]).distance_sq;
    }
    case ContactKind::vv:
      return point_point_distance_sq(x[a], x[b]);
  }
  return 0.0;
}

}  // namespace

CollisionDetector::CollisionDetector(const Topology& topo, const Positions& initial, ContactModel params,
                                     std::unique_ptr<BroadPhase> broad_phase)
    : topo_(topo), params_(params), prims_(build_collision_primitives(topo)), broad_(std::move(broad_phase)) {
  if (!broad_) throw Error("CollisionDetector: no broad phase given");
  if (static_cast<Index>(initial.size()) != topo.num_vertices())
    throw Error("CollisionDetector: " + std::to_string(initial.size()) + " initial positions for " +
                std::to_string(topo.num_vertices()) + " vertices");
  if (!(params_.radius > 0.0) || !(params_.offset >= 0.0) || !(params_.repulsion_range >= 0.0))
    throw Error("CollisionDetector: radius must be > 0, offset and repulsion_range >= 0");
  compute_primitive_boxes(prims_, topo_, initial,
                          box_inflation(params_.radius, params_.offset, params_.repulsion_range), boxes_);
  broad_->build(boxes_);
  // The triangles of one rigid body or one obstacle move as a whole and never meet (face_no_self):
  // one group per such object, so the broad phase never enumerates its internal pairs.
  std::vector<std::uint32_t> groups(static_cast<size_t>(prims_.size()), 0);
  for (Index f = 0; f < prims_.num_triangles; ++f)
    if (prims_.face_no_self[f]) groups[f] = static_cast<std::uint32_t>(topo_.face_object[f]) + 1;
  // Without any group the broad phase skips the per-pass group bookkeeping altogether.
  const bool grouped = std::any_of(groups.begin(), groups.end(), [](std::uint32_t g) { return g != 0; });
  broad_->set_groups(grouped ? std::span<const std::uint32_t>(groups) : std::span<const std::uint32_t>{});
  compute_exclusions(initial);
}

CollisionDetector::~CollisionDetector() = default;

void CollisionDetector::compute_exclusions(const Positions& initial) {
  // Obstacles are scripted: nothing between two obstacle primitives is ever constrained (see the
  // close sub-pairs below), so their pairs are not even enumerated.
  movable_.assign(static_cast<size_t>(prims_.size()), 0);
  for (Index p = 0; p < prims_.size(); ++p) {
    const Index e = prims_.element(p);
    auto obstacle = [&](Index v) { return topo_.objects[topo_.vertex_object[v]].kind == ObjectKind::obstacle; };
    switch (prims_.kind(p)) {
      case PrimitiveKind::triangle:
        movable_[p] = obstacle(topo_.faces[e][0]) && obstacle(topo_.faces[e][1]) && obstacle(topo_.faces[e][2]);
        break;
      case PrimitiveKind::edge:
        movable_[p] = obstacle(topo_.edges[e][0]) && obstacle(topo_.edges[e][1]);
        break;
      case PrimitiveKind::point:
        movable_[p] = obstacle(e);
        break;
    }
  }
  broad_->set_fixed(movable_);  // here: the obstacle flags
  broad_->query_pairs(candidates_);
  broad_->set_fixed({});
  const Index n = static_cast<Index>(candidates_.size());
  const Index chunks = default_chunk_count(n);
  std::vector<std::vector<CloseSubPair>> close(static_cast<size_t>(chunks));
  std::vector<std::vector<std::uint64_t>> crossing(static_cast<size_t>(chunks));
  std::atomic<Index> intersecting{0};
  // Within ξ + δ: mesh neighbours inside the repulsion band at rest are flagged too (no repulsion).
  const ClosestPoints cp{topo_, initial, params_.offset + params_.repulsion_range};
  parallel_chunks(n, chunks, [&](Index chunk, Index begin, Index end) {
    CloserThanOffsetSink close_sink{cp, close[chunk]};
    AllKeysSink all_sink{crossing[chunk]};
    Index local_intersecting = 0;
    for (Index i = begin; i < end; ++i) {
      auto [p, q] = candidates_[i];
      visit_sub_pairs(topo_, prims_, p, q, close_sink);
      // Intersecting triangle-triangle or triangle-segment pairs (paper §4.1): every sub-pair of
      // the primitive pair is excluded, since their closest points would give inverted normals.
      PrimitiveKind kp = prims_.kind(p), kq = prims_.kind(q);
      if (kp > kq) {
        std::swap(p, q);
        std::swap(kp, kq);
      }
      if (kp != PrimitiveKind::triangle || kq == PrimitiveKind::point) continue;
      const Vec3i& fa = topo_.faces[p];
      bool crosses = false;
      auto tri_crossed_by = [&](const Vec3i& f, const Vec2i& e) {
        return exact::segment_crosses_triangle(initial[e[0]], initial[e[1]], initial[f[0]], initial[f[1]],
                                               initial[f[2]]);
      };
      if (kq == PrimitiveKind::triangle) {
        if (prims_.face_no_self[p] && topo_.face_object[p] == topo_.face_object[q]) continue;
        const Vec3i& fb = topo_.faces[q];
        for (int k = 0; k < 3 && !crosses; ++k)
          crosses = tri_crossed_by(fb, topo_.edges[topo_.face_edges[p][k]]) ||
                    tri_crossed_by(fa, topo_.edges[topo_.face_edges[q][k]]);
        if (!crosses) continue;
        for (int k = 0; k < 3; ++k) {
          if (!has_vertex(fb, fa[k])) all_sink.vf(fa[k], q);
          if (!has_vertex(fa, fb[k])) all_sink.vf(fb[k], p);
          for (int l = 0; l < 3; ++l) {
            const Index ea = topo_.face_edges[p][k], eb = topo_.face_edges[q][l];
            if (!share_vertex(topo_.edges[ea], topo_.edges[eb])) all_sink.ee(ea, eb);
          }
        }
      } else {
        const Index e = prims_.element(q);
        const Vec2i& seg = topo_.edges[e];
        crosses = tri_crossed_by(fa, seg);
        if (!crosses) continue;
        for (int k = 0; k < 2; ++k)
          if (!has_vertex(fa, seg[k])) all_sink.vf(seg[k], p);
        for (int k = 0; k < 3; ++k)
          if (!share_vertex(topo_.edges[topo_.face_edges[p][k]], seg)) all_sink.ee(topo_.face_edges[p][k], e);
      }
      ++local_intersecting;
    }
    intersecting += local_intersecting;
  });
  proximity_ = InitialProximity{};
  proximity_.intersecting_pairs = intersecting.load();

  // Crossing primitive pairs: every sub-pair excluded (paper §4.1).
  std::vector<std::pair<std::uint64_t, Index>> entries;
  for (const auto& c : crossing)
    for (std::uint64_t k : c) entries.emplace_back(k, detail::InitialPairTable::kExcluded);
  std::sort(entries.begin(), entries.end());
  entries.erase(std::unique(entries.begin(), entries.end()), entries.end());
  proximity_.intersecting_excluded = static_cast<Index>(entries.size());
  auto crossing_key = [&](std::uint64_t k) {
    return std::binary_search(entries.begin(), entries.begin() + proximity_.intersecting_excluded,
                              std::make_pair(k, detail::InitialPairTable::kExcluded));
  };

  // Close sub-pairs in key order, so that slots do not depend on the chunking.
  std::vector<CloseSubPair> close_all;
  for (const auto& c : close) close_all.insert(close_all.end(), c.begin(), c.end());
  std::sort(close_all.begin(), close_all.end(),
            [](const CloseSubPair& x, const CloseSubPair& y) { return x.key < y.key; });
  close_all.erase(std::unique(close_all.begin(), close_all.end(),
                              [](const CloseSubPair& x, const CloseSubPair& y) { return x.key == y.key; }),
                  close_all.end());

  // Adjacency only around the vertices of close sub-pairs: on a fine mesh with a large ξ the
  // neighbourhoods are big, and most vertices never need one.
  TopologicalAdjacency adjacency;
  if (!close_all.empty()) {
    std::vector<std::uint8_t> sources(static_cast<size_t>(topo_.num_vertices()), 0);
    for (const CloseSubPair& c : close_all)
      for (Index v : c.va)
        if (v >= 0) sources[v] = 1;
    adjacency = TopologicalAdjacency(topo_, initial, kAdjacencyRadiusInOffsets * params_.offset, sources);
  }
  // Pairs only in the repulsion band (ξ <= d0 < ξ + δ) are mesh neighbours, exempt from repulsion,
  // within 2 (ξ + δ) plus the longest edge along the mesh: on a surface whose edges are longer than
  // 2ξ (the knot's 5 mm against ξ = 2 mm, δ = 1 mm) a face one ring away is already further than
  // 2ξ along the edges, and repulsion pushed such pairs apart every substep (1 mm of distortion).
  TopologicalAdjacency band_adjacency;
  {
    std::vector<std::uint8_t> sources(static_cast<size_t>(topo_.num_vertices()), 0);
    bool any = false;
    for (const CloseSubPair& c : close_all)
      if (!(c.distance < params_.offset))
        for (Index v : c.va)
          if (v >= 0) sources[v] = 1, any = true;
    if (any) {
      double longest = 0.0;
      for (Index e = 0; e < topo_.num_edges(); ++e) {
        const ObjectKind k = topo_.objects[topo_.edge_object[e]].kind;
        if (k == ObjectKind::obstacle || k == ObjectKind::rigid) continue;
        longest = std::max(longest, (initial[topo_.edges[e][1]] - initial[topo_.edges[e][0]]).norm());
      }
      band_adjacency = TopologicalAdjacency(
          topo_, initial, kAdjacencyRadiusInOffsets * (params_.offset + params_.repulsion_range) + longest, sources);
    }
  }
  reduced_key_.clear();
  reduced_offset_.clear();
  reduced_fixed_.clear();
  auto on_obstacle = [&](std::span<const Index> vs) {
    for (Index v : vs)
      if (topo_.objects[topo_.vertex_object[v]].kind != ObjectKind::obstacle) return false;
    return true;
  };
  Index band_neighbours = 0;
  for (const CloseSubPair& c : close_all) {
    if (crossing_key(c.key)) continue;
    const std::span<const Index> va(c.va.data(), c.va[1] >= 0 ? 2 : 1);
    const std::span<const Index> vb(c.vb.data(), c.vb[2] >= 0 ? 3 : (c.vb[1] >= 0 ? 2 : 1));
    if (on_obstacle(va) && on_obstacle(vb)) continue;  // scripted on both sides: never constrained
    // Neighbours on a mesh finer than ξ keep contact too, at their rest distance less the margin,
    // never raised: raising would stiffen the material (a stretched pair could not relax back),
    // excluding them let a held-back soft knot intersect itself unseen (issue #39).
    const bool close_to_offset = c.distance < params_.offset;
    const bool adjacent = close_to_offset ? adjacency.adjacent(va, vb) : band_adjacency.adjacent(va, vb);
    if (!close_to_offset && !adjacent) continue;  // only in the repulsion band: an ordinary pair
    entries.emplace_back(c.key, static_cast<Index>(reduced_key_.size()));
    reduced_key_.push_back(c.key);
    // Neighbours between ξ and ξ + δ keep ξ and only lose the repulsion (ContactPair::neighbours).
    reduced_offset_.push_back(close_to_offset ? (1.0 - kInitialOffsetMargin) * c.distance : params_.offset);
    reduced_fixed_.push_back(adjacent ? 1 : 0);
    if (adjacent && close_to_offset) ++proximity_.adjacent_kept;
    if (!close_to_offset) ++band_neighbours;
  }
  proximity_.reduced_offset = static_cast<Index>(reduced_key_.size()) - proximity_.adjacent_kept - band_neighbours;
  proximity_.min_reduced_offset = std::numeric_limits<double>::infinity();
  for (size_t i = 0; i < reduced_offset_.size(); ++i)
    if (!reduced_fixed_[i]) proximity_.min_reduced_offset = std::min(proximity_.min_reduced_offset, reduced_offset_[i]);
  if (proximity_.reduced_offset == 0) proximity_.min_reduced_offset = 0.0;
  active_.clear();
  for (size_t i = 0; i < reduced_key_.size(); ++i)
    if (!reduced_fixed_[i]) active_.push_back(static_cast<Index>(i));
  initial_.assign(std::move(entries));

  // Shortest edge of the deformable objects, for the warning on ξ against the mesh resolution.
  proximity_.shortest_edge = std::numeric_limits<double>::infinity();
  Index shortest_object = -1;
  for (Index e = 0; e < topo_.num_edges(); ++e) {
    const Index o = topo_.edge_object[e];
    const ObjectKind k = topo_.objects[o].kind;
    if (k == ObjectKind::obstacle || k == ObjectKind::rigid) continue;
    const double len = (initial[topo_.edges[e][1]] - initial[topo_.edges[e][0]]).norm();
    if (len < proximity_.shortest_edge) proximity_.shortest_edge = len, shortest_object = o;
  }

  const InitialProximity& ip = proximity_;
  log::info(
      "collision: {} primitives; initial configuration: {} sub-pairs closer than the offset {} ({} adjacent, "
      "kept with a fixed reduced offset; {} others kept with a rising reduced offset), {} intersecting primitive "
      "pairs ({} sub-pairs excluded)",
      prims_.size(),
      std::count_if(close_all.begin(), close_all.end(),
                    [&](const CloseSubPair& c) { return c.distance < params_.offset; }),
      params_.offset, ip.adjacent_kept, ip.reduced_offset, ip.intersecting_pairs, ip.intersecting_excluded);
  if (ip.reduced_offset > 0)
    log::warn(
        "collision: {} sub-pairs that are not neighbours on a mesh start closer than the offset {} (closest "
        "{:.4g}); they keep contact with their initial distance less {:.0f}% as offset, raised toward {} as they "
        "separate",
        ip.reduced_offset, params_.offset, ip.min_reduced_offset / (1.0 - kInitialOffsetMargin),
        100.0 * kInitialOffsetMargin, params_.offset);
  if (ip.adjacent_kept > 0 && shortest_object >= 0)
    log::warn(
        "collision: the offset {} is large against the mesh (shortest edge {:.4g} in object '{}'): {} sub-pairs "
        "joined by a path of at most {:.4g} along the mesh start closer than the offset; they keep their rest "
        "distance less {:.0f}% as offset for the run, so the surface resists being compressed more than that "
        "there (docs/choosing-parameters.md, \"Meshes finer than xi\")",
        params_.offset, ip.shortest_edge, topo_.objects[shortest_object].name, ip.adjacent_kept,
        kAdjacencyRadiusInOffsets * params_.offset, 100.0 * kInitialOffsetMargin);
  if (ip.intersecting_pairs > 0)
    log::warn(
        "collision: {} primitive pairs intersect in the initial configuration; their {} sub-pairs are excluded "
        "for the run",
        ip.intersecting_pairs, ip.intersecting_excluded);
}

double separation_lower_bound(const ContactPair& c, const std::vector<Vec3>& x) {
  double scale = 0.0;
  for (int k = 0; k < c.size(); ++k) scale = std::max(scale, x[static_cast<size_t>(c.v[k])].cwiseAbs().sum());
  return separation_lower_bound(c, x, scale);
}

double CollisionDetector::pair_offset(ContactKind kind, Index a, Index b) const {
  const Index slot = initial_.find(kind, a, b);
  return slot >= 0 ? reduced_offset_[static_cast<size_t>(slot)] : params_.offset;
}

void CollisionDetector::restore_reduced_offsets(std::span<const double> offsets) {
  if (offsets.size() != reduced_offset_.size())
    throw Error("collision state: " + std::to_string(offsets.size()) + " reduced offsets given, this scene has " +
                std::to_string(reduced_offset_.size()) + " sub-pairs that start closer than the offset");
  const double xi = params_.offset;
  for (size_t i = 0; i < offsets.size(); ++i)
    if (!std::isfinite(offsets[i]) || offsets[i] < reduced_offset_[i] || offsets[i] > xi)
      throw Error(
          ccfr::format("collision state: reduced offset {} is {:.17g}, outside [{:.17g}, {:.17g}] (its initial "
                       "value and the offset)",
                       i, offsets[i], reduced_offset_[i], xi));
  for (size_t i = 0; i < offsets.size(); ++i)
    if (reduced_fixed_[i] && offsets[i] != reduced_offset_[i])
      throw Error(
          ccfr::format("collision state: reduced offset {} belongs to an adjacent sub-pair and is fixed at "
                       "{:.17g}, got {:.17g}",
                       i, reduced_offset_[i], offsets[i]));
  reduced_offset_.assign(offsets.begin(), offsets.end());
  // Exactly the slots raise_reduced_offsets() would have kept: those still below ξ, ascending,
  // except the adjacent ones, which never rise.
  active_.clear();
  for (size_t i = 0; i < reduced_offset_.size(); ++i) {
    if (reduced_offset_[i] < xi && !reduced_fixed_[i]) active_.push_back(static_cast<Index>(i));
  }
}

/// Initial proximity: \f$\xi_p \leftarrow \min(\xi, \max(\xi_p, (1 - m)\,d))\f$ at the anchors,
/// which are feasible (d ≥ ξ_p), so the raised offset never exceeds the distance. One slot per
/// task: no two writes meet, and the result does not depend on the thread count.
void CollisionDetector::raise_reduced_offsets(const Positions& x) {
  const double xi = params_.offset;
  parallel_for(
      static_cast<Index>(active_.size()),
      [&](Index b, Index e) {
        for (Index i = b; i < e; ++i) {
          const Index slot = active_[i];
          const double d = std::sqrt(key_distance_sq(topo_, x, reduced_key_[slot]));
          const double raised = std::min(xi, (1.0 - kInitialOffsetMargin) * d);
          if (raised > reduced_offset_[slot]) reduced_offset_[slot] = raised;  // NaN compares false: kept
        }
      },
      1024);
  active_.erase(
      std::remove_if(active_.begin(), active_.end(), [&](Index slot) { return !(reduced_offset_[slot] < xi); }),
      active_.end());
}

void CollisionDetector::set_reuse_skin(double skin) {
  if (!(skin >= 0.0) || !std::isfinite(skin))
    throw Error("CollisionDetector::set_reuse_skin: the skin must be finite and >= 0, got " + std::to_string(skin));
  skin_ = skin;
  list_valid_ = false;
  if (skin_ == 0.0) {
    list_.clear();
    list_.shrink_to_fit();
  }
}

ReuseMotion measure_reuse_motion(const Topology& topo, std::span<const Vec3> x, std::span<const Vec3> ref,
                                 double* per_vertex) {
  const Index n = topo.num_vertices();
  if (static_cast<Index>(x.size()) != n || static_cast<Index>(ref.size()) != n)
    throw Error("measure_reuse_motion: expected " + std::to_string(n) + " positions, got " + std::to_string(x.size()) +
                " and " + std::to_string(ref.size()));
  constexpr double kInf = std::numeric_limits<double>::infinity();
  const size_t num_objects = topo.objects.size();
  ReuseMotion m;
  m.still.assign(num_objects, 1);
  // Per object: whether any vertex moved (objects are contiguous vertex ranges, so this is cheap).
  for (size_t o = 0; o < num_objects; ++o) {
    const ObjectInfo& ob = topo.objects[o];
    for (Index v = ob.vertex_begin; v < ob.vertex_end; ++v)
      if (!(x[v] == ref[v])) {  // NaN counts as moved
        m.still[o] = 0;
        break;
      }
  }
  // Box of the moving objects' displacements and their largest length; maxima and minima only,
  // so the chunked reduction is exact for any thread count.
  const Index chunks = default_chunk_count(n);
  std::vector<AABB> boxes(static_cast<size_t>(chunks));
  std::vector<double> largest(static_cast<size_t>(chunks), 0.0);
  auto moving = [&](Index v) { return !m.still[static_cast<size_t>(topo.vertex_object[v])]; };
  parallel_chunks(n, chunks, [&](Index c, Index b, Index e) {
    AABB box;
    double l = 0.0;
    for (Index v = b; v < e; ++v) {
      if (!moving(v)) continue;
      const Vec3 d = x[v] - ref[v];
      const double len = d.norm();
      l = std::isnan(len) ? kInf : std::max(l, len);
      box.expand(d);
    }
    boxes[c] = box;
    largest[c] = l;
  });
  AABB all;
  for (Index c = 0; c < chunks; ++c) {
    all.expand(boxes[c]);
    m.largest = std::max(m.largest, largest[c]);
  }
  if (!std::isfinite(m.largest)) {
    m.spread = m.largest = kInf;
    if (per_vertex) std::fill(per_vertex, per_vertex + n, kInf);
    return m;
  }
  // The box centre is usually far better than t = 0 (a falling scene), but not always (the box of
  // a few displacements on a sphere can be off-centre): take whichever bounds the spread lower.
  const Vec3 centre = all.valid() ? all.center() : Vec3::Zero();
  std::vector<double> spread(static_cast<size_t>(chunks), 0.0);
  parallel_chunks(n, chunks, [&](Index c, Index b, Index e) {
    double s = 0.0;
    for (Index v = b; v < e; ++v)
      if (moving(v)) s = std::max(s, (x[v] - ref[v] - centre).norm());
    spread[c] = s;
  });
  const double centred = *std::max_element(spread.begin(), spread.end());
  if (centred < m.largest) {
    m.shift = centre;
    m.spread = centred;
  } else {
    m.spread = m.largest;
  }
  if (per_vertex) {
    const Vec3 t = m.shift;
    parallel_chunks(n, chunks, [&](Index, Index b, Index e) {
      for (Index v = b; v < e; ++v) {
        const double d = (x[v] - ref[v] - t).norm();
        per_vertex[v] = std::isnan(d) ? kInf : d;
      }
    });
  }
  return m;
}

namespace {
/// Euclidean distance between two boxes (0 if they overlap).
double box_distance(const AABB& a, const AABB& b) {
  const Vec3 gap = (a.lo - b.hi).cwiseMax(b.lo - a.hi).cwiseMax(0.0);
  return gap.norm();
}
}  // namespace

bool CollisionDetector::list_covers(const Positions& x, std::span<const double> inv_mass) {
  const Index nv = topo_.num_vertices();
  if (static_cast<Index>(list_x_.size()) != nv || static_cast<Index>(list_movable_.size()) != nv) return false;
  for (Index v = 0; v < nv; ++v)
    if (list_movable_[v] != static_cast<std::uint8_t>(inv_mass[v] > 0.0)) return false;
  disp_.resize(static_cast<size_t>(nv));
  // A NaN gives infinity and fails the check: the pass then runs the broad phase, which reports it.
  const ReuseMotion m = measure_reuse_motion(topo_, x, list_x_, disp_.data());
  const double reach = 2.0 * params_.radius + params_.offset;
  // The relative margin covers the rounding of the listed distances and of the displacements.
  auto fits = [&](double move, double room) { return move <= room * (1.0 - 1e-9) - 1e-9 * reach; };
  // Two moving sides: each within `spread` of its listing position shifted by t, so a sub-pair
  // beyond 2r + ξ + s at listing is still beyond 2r + ξ while 2 spread <= s.
  if (!fits(2.0 * m.spread, skin_)) return false;
  // A moving side against a still one: the still side stayed put, so the pair came closer by at
  // most `largest`; it was at least max(2r + ξ + s, g) apart, g the distance of the boxes at listing.
  AABB movers;
  bool any_still = false;
  for (size_t o = 0; o < m.still.size(); ++o) {
    if (topo_.objects[o].num_vertices() == 0) continue;
    if (m.still[o])
      any_still = true;
    else
      movers.expand(list_boxes_[o]);
  }
  if (!any_still || !movers.valid()) return true;
  double gap = std::numeric_limits<double>::infinity();
  for (size_t o = 0; o < m.still.size(); ++o)
    if (m.still[o] && topo_.objects[o].num_vertices() > 0) gap = std::min(gap, box_distance(list_boxes_[o], movers));
  return fits(m.largest, std::max(skin_, gap - reach));
}

double CollisionDetector::step_since_last_pass(const Positions& x) {
  double step = std::numeric_limits<double>::infinity();
  if (restart_step_ >= 0.0)
    step = restart_step_;
  else if (last_x_.size() == x.size())
    step = measure_reuse_motion(topo_, x, last_x_).spread;
  restart_step_ = -1.0;
  last_x_ = x;
  return step;
}

void CollisionDetector::restart_reuse(double recent_step) {
  list_valid_ = false;
  last_x_.clear();
  restart_step_ = std::isfinite(recent_step) && recent_step >= 0.0 ? recent_step : -1.0;
}

void CollisionDetector::detect_from_list(const Positions& x, std::span<const double> inv_mass, DetectionStats& stats) {
  const Index chunks = static_cast<Index>(list_.size());
  contact_buffers_.resize(static_cast<size_t>(chunks));
  for (auto& b : contact_buffers_) b.clear();
  std::vector<DetectionStats> counts(static_cast<size_t>(chunks));
  const double reach = 2.0 * params_.radius + params_.offset;
  // A listed sub-pair is evaluated unless its lower bound (listed distance less the largest
  // displacement of each side) already clears the range, with a margin for rounding.
  const double clear = reach * (1.0 + 1e-9) + 1e-12;
  parallel_chunks(chunks, chunks, [&](Index chunk, Index, Index) {
    DetectSink sink{
        topo_, x, inv_mass, initial_, reduced_offset_, params_.offset, reach, reach * reach, contact_buffers_[chunk]};
    sink.fixed = reduced_fixed_.data();
    const auto& d = disp_;
    for (const detail::ListedSubPair& p : list_[chunk]) {
      const double listed = p.distance;
      switch (p.kind) {
        case ContactKind::vf: {
          const Vec3i& t = topo_.faces[p.b];
          if (listed - d[p.a] - std::max({d[t[0]], d[t[1]], d[t[2]]}) >= clear) continue;
          sink.vf_eval(p.a, p.b, p.slot);
          break;
        }
        case ContactKind::ee: {
          const Vec2i &ea = topo_.edges[p.a], &eb = topo_.edges[p.b];
          if (listed - std::max(d[ea[0]], d[ea[1]]) - std::max(d[eb[0]], d[eb[1]]) >= clear) continue;
          sink.ee_eval(p.a, p.b, p.slot);
          break;
        }
        case ContactKind::ve: {
          const Vec2i& e = topo_.edges[p.b];
          if (listed - d[p.a] - std::max(d[e[0]], d[e[1]]) >= clear) continue;
          sink.ve_eval(p.a, p.b, p.slot);
          break;
        }
        case ContactKind::vv:
          if (listed - d[p.a] - d[p.b] >= clear) continue;
          sink.vv_eval(p.a, p.b, p.slot);
          break;
      }
    }
    sink.add_to(counts[chunk]);
  });
  for (Index c = 0; c < chunks; ++c) {
    add_counts(stats, counts[c]);
    stats.listed += static_cast<Index>(list_[c].size());
  }
}

void CollisionDetector::detect(const Positions& x, std::span<const double> inv_mass, RegionSet& regions,
                               std::vector<ContactPair>& contacts, DetectionStats& stats,
                               std::span<const Vec3> kinematic_step) {
  const Index nv = topo_.num_vertices();
  if (!kinematic_step.empty() && static_cast<Index>(kinematic_step.size()) != nv)
    throw Error("CollisionDetector::detect: kinematic_step has " + std::to_string(kinematic_step.size()) +
                " entries, expected " + std::to_string(nv));
  if (static_cast<Index>(x.size()) != nv || static_cast<Index>(inv_mass.size()) != nv)
    throw Error("CollisionDetector::detect: expected " + std::to_string(nv) + " positions and inverse masses, got " +
                std::to_string(x.size()) + " and " + std::to_string(inv_mass.size()));
  stats = DetectionStats{};
  Stopwatch watch;
  SerialStopwatch serial;
  const double step = skin_ > 0.0 ? step_since_last_pass(x) : 0.0;
  if (skin_ > 0.0 && list_valid_ && list_covers(x, inv_mass)) {
    stats.reused = true;
    stats.broad_s = watch.seconds();
    stats.broad_serial_s = serial.seconds();
    watch.restart();
    serial = SerialStopwatch();
    if (!active_.empty()) raise_reduced_offsets(x);
    detect_from_list(x, inv_mass, stats);
    assemble(x, inv_mass, kinematic_step, contacts, regions);
    stats.constraints = static_cast<Index>(regions.total());
    stats.narrow_s = watch.seconds();
    stats.narrow_serial_s = serial.seconds();
    return;
  }
  list_valid_ = false;
  // List only if the last pass's motion, repeated, would leave the list valid for two passes: a list
  // that serves one pass costs more than it saves (larger boxes, kernels up to 2r + ξ + s).
  const bool listing = skin_ > 0.0 && 4.0 * step < skin_;
  // A primitive with no movable vertex can only meet another immovable one in vain: such pairs
  // are never enumerated (a static obstacle against itself would dominate the broad phase).
  movable_.resize(static_cast<size_t>(prims_.size()));
  fixed_.resize(static_cast<size_t>(prims_.size()));
  parallel_for(
      prims_.size(),
      [&](Index begin, Index end) {
        for (Index p = begin; p < end; ++p) {
          const Index e = prims_.element(p);
          switch (prims_.kind(p)) {
            case PrimitiveKind::triangle:
              movable_[p] =
                  inv_mass[topo_.faces[e][0]] > 0 || inv_mass[topo_.faces[e][1]] > 0 || inv_mass[topo_.faces[e][2]] > 0;
              break;
            case PrimitiveKind::edge:
              movable_[p] = inv_mass[topo_.edges[e][0]] > 0 || inv_mass[topo_.edges[e][1]] > 0;
              break;
            case PrimitiveKind::point:
              movable_[p] = inv_mass[e] > 0;
              break;
          }
          fixed_[p] = !movable_[p];
        }
      },
      4096);
  // Building the list: boxes grown by s/2 more, so pairs within 2r + ξ + s come up.
  const double inflation = box_inflation(params_.radius, params_.offset, params_.repulsion_range);
  if (rebuild_ && listing) {
    // The tree is built over the boxes a pass without the list uses, then refitted to the grown
    // ones: a tree built over grown boxes splits differently and enumerates in another order, so
    // the contacts came out reordered and the frames differed in the last bits (card stack, three
    // cubes, particles from the fifth frame on).
    compute_primitive_boxes(prims_, topo_, x, inflation, boxes_);
    broad_->build(boxes_);
    rebuild_ = false;
  }
  compute_primitive_boxes(prims_, topo_, x, inflation + (listing ? 0.5 * skin_ : 0.0), boxes_);
  if (rebuild_) {
    broad_->build(boxes_);
    rebuild_ = false;
  } else {
    broad_->update(boxes_);
  }
  broad_->set_fixed(fixed_);
  broad_->query_pairs(candidates_);
  stats.broad_s = watch.seconds();
  stats.broad_serial_s = serial.seconds();
  stats.candidates = static_cast<Index>(candidates_.size());

  watch.restart();
  serial = SerialStopwatch();
  if (!active_.empty()) raise_reduced_offsets(x);

  const Index n = stats.candidates;
  const Index chunks = default_chunk_count(n);
  contact_buffers_.resize(static_cast<size_t>(chunks));
  for (auto& b : contact_buffers_) b.clear();
  std::vector<DetectionStats> counts(static_cast<size_t>(chunks));
  // Without listing the old chunks stay allocated but invalid: the next listing pass refills them.
  if (listing) list_.resize(static_cast<size_t>(chunks));
  parallel_chunks(n, chunks, [&](Index chunk, Index begin, Index end) {
    const double reach = 2.0 * params_.radius + params_.offset;
    DetectSink sink{
        topo_, x, inv_mass, initial_, reduced_offset_, params_.offset, reach, reach * reach, contact_buffers_[chunk]};
    sink.fixed = reduced_fixed_.data();
    if (listing) {
      list_[chunk].clear();
      sink.list = &list_[chunk];
      sink.list_reach = reach + skin_;
      sink.list_reach_sq = sink.list_reach * sink.list_reach;
    }
    for (Index i = begin; i < end; ++i) {
      const auto [p, q] = candidates_[i];
      if (movable_[p] || movable_[q]) visit_sub_pairs(topo_, prims_, p, q, sink);
    }
    sink.add_to(counts[chunk]);
  });
  for (Index c = 0; c < chunks; ++c) {
    add_counts(stats, counts[c]);
    if (listing) stats.listed += static_cast<Index>(list_[c].size());
  }
  if (listing) {
    list_x_ = x;
    list_boxes_.assign(topo_.objects.size(), AABB{});
    for (size_t o = 0; o < topo_.objects.size(); ++o)
      for (Index v = topo_.objects[o].vertex_begin; v < topo_.objects[o].vertex_end; ++v) list_boxes_[o].expand(x[v]);
    list_movable_.resize(static_cast<size_t>(nv));
    for (Index v = 0; v < nv; ++v) list_movable_[v] = inv_mass[v] > 0.0;
    list_valid_ = true;
  }
  assemble(x, inv_mass, kinematic_step, contacts, regions);
  stats.constraints = static_cast<Index>(regions.total());
  stats.narrow_s = watch.seconds();
  stats.narrow_serial_s = serial.seconds();
}

/// Concatenates the per-chunk contacts in chunk order (deterministic for any thread count) and
/// applies Alg. NarrowPhase lines 10, 26 and 41 to every contact: each movable vertex of side A
/// gets \f$ (\mathbf{n}, s_A\varphi) \f$, each of side B \f$ (-\mathbf{n}, s_B\varphi) \f$ (the
/// normal points from the other primitive toward the vertex's own, clarification 3); d stays negative for a pair
/// already inside the offset (clarification 7).
///
/// The CSR is filled in parallel without sorting: the chunks are grouped into at most 32 fixed
/// blocks of consecutive chunks, each block counts its planes per vertex, and prefix sums over
/// (vertex, block) give every block its own write cursor per vertex. A vertex's planes thus
/// appear in contact order, which depends neither on the thread count nor on timing. The copy
/// of the contacts into `contacts` happens in the same sweep as the plane writes, so each
/// contact buffer is read twice (count, fill) instead of three times.
namespace {
/// Whether the split d = s G can leave the pair inside its offset when G < 0: the movable vertices
/// then move away from the other side, but fixed vertices among them (or on both sides) do not.
bool split_cannot_close(const ContactPair& c, std::span<const double> inv_mass) {
  bool fixed[2] = {false, false}, movable[2] = {false, false};
  const int na = c.side_a();
  for (int k = 0; k < c.size(); ++k) (inv_mass[c.v[k]] > 0.0 ? movable : fixed)[k < na ? 0 : 1] = true;
  return (fixed[0] && fixed[1]) || (fixed[0] && movable[0]) || (fixed[1] && movable[1]);
}

/// Extremes of a contact's vertices along m: side A's lowest, side B's highest, over the movable
/// vertices at x and over the fixed ones at their end positions (±infinity where a side has none).
struct SideExtremes {
  double free_a = std::numeric_limits<double>::infinity(), fixed_a = free_a;
  double free_b = -free_a, fixed_b = -free_a;
};

SideExtremes side_extremes(const ContactPair& c, const Vec3& m, const std::vector<Vec3>& x,
                           std::span<const double> inv_mass, std::span<const Vec3> step) {
  SideExtremes e;
  const int na = c.side_a();
  for (int k = 0; k < c.size(); ++k) {
    const Index v = c.v[k];
    const bool movable = inv_mass[v] > 0.0;
    const double along = m.dot(movable || step.empty() ? x[v] : Vec3(x[v] + step[v]));
    if (k < na) {
      double& lowest = movable ? e.free_a : e.fixed_a;
      lowest = std::min(lowest, along);
    } else {
      double& highest = movable ? e.free_b : e.fixed_b;
      highest = std::max(highest, along);
    }
  }
  return e;
}
}  // namespace

std::optional<RegionRecord> mixed_pair_record(const ContactPair& c, const std::vector<Vec3>& x,
                                              std::span<const double> inv_mass, std::span<const Vec3> kinematic_step,
                                              double share_a) {
  const double need = c.offset;
  // A relative margin above round-off, so that the fixed vertices' slab is not a tie.
  const double keep = need * (1.0 + 1e-6);
  auto margin = [&](const Vec3& m) {
    const SideExtremes e = side_extremes(c, m, x, inv_mass, kinematic_step);
    return e.fixed_a - e.fixed_b;  // +infinity unless both sides hold fixed vertices
  };
  Vec3 m = c.n;
  if (!(margin(m) >= keep)) {
    // The fixed vertices' own separating direction: their closest points (a side holds at most
    // two fixed vertices when the pair has a movable one: a vertex, or an edge's two ends).
    std::vector<Vec3> fa, fb;
    const int na = c.side_a();
    for (int k = 0; k < c.size(); ++k) {
      const Index v = c.v[k];
      if (inv_mass[v] > 0.0) continue;
      (k < na ? fa : fb).push_back(kinematic_step.empty() ? x[v] : Vec3(x[v] + kinematic_step[v]));
    }
    Vec3 apart;
    if (fa.size() == 1 && fb.size() == 1)
      apart = fa[0] - fb[0];
    else if (fa.size() == 1 && fb.size() == 2)
      apart = fa[0] - point_edge(fa[0], fb[0], fb[1]).closest;
    else if (fa.size() == 2 && fb.size() == 1)
      apart = point_edge(fb[0], fa[0], fa[1]).closest - fb[0];
    else
      return std::nullopt;
    const double far = apart.norm();
    if (!(far >= keep)) return std::nullopt;  // the fixed vertices alone end inside the offset
    const Vec3 best = apart / far;
    // The smallest turn from n toward `best` that separates the fixed vertices by the offset
    // (feasible at t = 1); the free vertices then move as little as this plane allows.
    double lo = 0.0, hi = 1.0;
    for (int it = 0; it < 40; ++it) {
      const double t = 0.5 * (lo + hi);
      const Vec3 u = (1.0 - t) * c.n + t * best;
      const double len = u.norm();
      if (len > 1e-12 && margin(u / len) >= keep)
        hi = t;
      else
        lo = t;
    }
    m = ((1.0 - hi) * c.n + hi * best).normalized();
    if (!(margin(m) >= keep)) m = best;
  }
  const SideExtremes e = side_extremes(c, m, x, inv_mass, kinematic_step);
  const bool free_a = std::isfinite(e.free_a), free_b = std::isfinite(e.free_b);
  if (!free_a && !free_b) return std::nullopt;
  // Ends of A (a) and of B (b) along m for the movable vertices: the usual mass-weighted split of
  // their room when both sides move, then kept the offset clear of the other side's fixed ones.
  double a = std::numeric_limits<double>::infinity(), b = -a;
  if (free_a && free_b) {
    const double room = e.free_a - e.free_b - need;
    a = e.free_a - share_a * room;
    b = e.free_b + (1.0 - share_a) * room;
  } else if (free_a) {
    a = e.free_a;
  } else {
    b = e.free_b;
  }
  if (free_a && std::isfinite(e.fixed_b)) a = free_b ? std::max(a, e.fixed_b + keep) : e.fixed_b + keep;
  if (free_b && std::isfinite(e.fixed_a)) b = free_a ? std::min(b, e.fixed_a - keep) : e.fixed_a - keep;
  RegionRecord rec;
  rec.n = m;
  rec.d[0] = free_a ? e.free_a - a : 0.0;  // side A: m·x' >= m·x - d_A >= a
  rec.d[1] = free_b ? b - e.free_b : 0.0;  // side B: m·x' <= m·x + d_B <= b
  return rec;
}

void CollisionDetector::assemble(const Positions& x, std::span<const double> inv_mass,
                                 std::span<const Vec3> kinematic_step, std::vector<ContactPair>& contacts,
                                 RegionSet& regions) {
  const Index nv = topo_.num_vertices();
  const Index chunks = static_cast<Index>(contact_buffers_.size());
  std::vector<size_t> start(static_cast<size_t>(chunks) + 1, 0);
  for (Index c = 0; c < chunks; ++c) start[c + 1] = start[c] + contact_buffers_[c].size();
  contacts.resize(start.back());
  regions.row_start.assign(static_cast<size_t>(nv) + 1, 0);
  if (start.back() > std::numeric_limits<std::uint32_t>::max() / 2)
    throw Error("CollisionDetector::detect: " + std::to_string(start.back()) +
                " contacts exceed the region's 32-bit plane references");
  regions.records.resize(start.back());  // every record is written below
  if (contacts.empty()) {
    regions.refs.clear();
    plane_sources_.clear();
    return;
  }
  // Blocks x vertices cursors cost as much as the scatter they split once the contacts are few (a
  // pass that moves a handful of vertices): about 1,024 contacts per block, at most 32.
  const Index blocks = std::clamp<Index>(static_cast<Index>(start.back() / 1024), 1, std::min<Index>(chunks, 32));
  block_cursor_.resize(static_cast<size_t>(blocks) * nv);
  parallel_chunks(chunks, blocks, [&](Index b, Index chunk_begin, Index chunk_end) {
    Index* count = block_cursor_.data() + static_cast<size_t>(b) * nv;
    std::fill(count, count + nv, 0);
    for (Index chunk = chunk_begin; chunk < chunk_end; ++chunk)
      for (const ContactPair& c : contact_buffers_[chunk])
        for (int k = 0; k < c.size(); ++k)
          if (inv_mass[c.v[k]] > 0.0) ++count[c.v[k]];
  });
  counts_to_block_cursors(nv, blocks, block_cursor_, regions.row_start);
  regions.refs.resize(static_cast<size_t>(regions.row_start.back()));
  // Every entry is written below: resizing without clearing first skips zero-filling them.
  plane_sources_.resize(record_sources_ ? regions.refs.size() : 0);
  parallel_chunks(chunks, blocks, [&](Index b, Index chunk_begin, Index chunk_end) {
    Index* cursor = block_cursor_.data() + static_cast<size_t>(b) * nv;
    for (Index chunk = chunk_begin; chunk < chunk_end; ++chunk) {
      ContactPair* out = contacts.data() + start[chunk];
      for (const ContactPair& c : contact_buffers_[chunk]) {
        const size_t ci = static_cast<size_t>(out - contacts.data());
        const Index slot0 = 4 * static_cast<Index>(ci);
        *out++ = c;
        const double phi = c.distance - c.offset;
        // Gap left to the movable vertices: phi plus the known approach of kinematic vertices
        // (their steps are zero for dynamic vertices, so the sum runs over all of c's vertices).
        // The closest points are separated by the plane normal to n; every vertex of a side must
        // stay behind its plane, so a kinematic side is bounded by its worst-moving vertex (a
        // rotating handle's far corner can approach faster than its closest point):
        // G = phi - K_A - K_B with K the largest approach of a side's scripted vertices along n.
        double gap = phi;
        if (!kinematic_step.empty()) {
          const int na_k = c.side_a();
          double k_a = 0.0, k_b = 0.0;
          for (int k = 0; k < c.size(); ++k) {
            const double along = c.n.dot(kinematic_step[c.v[k]]);  // zero for dynamic vertices
            if (k < na_k)
              k_a = std::max(k_a, -along);
            else
              k_b = std::max(k_b, along);
          }
          gap -= k_a + k_b;
        }
        const double s_a = share_a(c, inv_mass), s_b = 1.0 - s_a;
        const int na = c.side_a();
        // One record per contact; each movable vertex's slot refers to it and its side.
        regions.records[ci] = {c.n, {s_a * gap, s_b * gap}};
        if (gap < 0.0 && split_cannot_close(c, inv_mass))
          if (const auto mixed = mixed_pair_record(c, x, inv_mass, kinematic_step, s_a)) regions.records[ci] = *mixed;
        const std::uint32_t ref = 2 * static_cast<std::uint32_t>(ci);
        for (int k = 0; k < c.size(); ++k) {
          const Index v = c.v[k];
          if (!(inv_mass[v] > 0.0)) continue;
          if (record_sources_) plane_sources_[static_cast<size_t>(cursor[v])] = slot0 + k;
          regions.refs[static_cast<size_t>(cursor[v]++)] = ref + (k < na ? 0u : 1u);
        }
      }
    }
  });
}

}  // namespace ccfr
