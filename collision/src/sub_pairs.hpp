#pragma once
/// @file sub_pairs.hpp
/// Narrow-phase stage 1 (private): the sub-pairs of a primitive pair and their closest points.
/// One enumeration and one closest-point implementation serve both passes that need them: the
/// initial configuration's (initial_proximity.cpp) and every detection pass (contact_sink.hpp).
#include <array>
#include <cstdint>
#include <utility>

#include "ccfr/collision/collision_detector.hpp"
#include "ccfr/collision/primitives.hpp"
#include "ccfr/core/topology.hpp"
#include "ccfr/geometry/distance.hpp"

namespace ccfr::detail {

inline double square(double a) { return a * a; }
inline bool has_vertex(const Vec3i& f, Index v) { return f[0] == v || f[1] == v || f[2] == v; }
inline bool share_vertex(const Vec2i& a, const Vec2i& b) {
  return a[0] == b[0] || a[0] == b[1] || a[1] == b[0] || a[1] == b[1];
}
/// Whether boxes [alo, ahi] and [blo, bhi] come within `reach` (m) per axis: false means farther.
inline bool boxes_within(const Vec3& alo, const Vec3& ahi, const Vec3& blo, const Vec3& bhi, double reach) {
  return (alo.array() <= bhi.array() + reach).all() && (blo.array() <= ahi.array() + reach).all();
}

/// Calls sink.vf / ee / ve / vv once per sub-pair of the primitive pair (p, q), in either order.
/// kRepresented: only the vertices and edges each primitive represents (Curtis et al. 2008), so
/// that over all primitive pairs each sub-pair comes up exactly once; otherwise all of them (every
/// sub-pair of a crossing pair). Sub-pairs sharing a vertex are skipped, and so are pairs of
/// triangles of one rigid or obstacle object (face_no_self). Always inlined: a call per candidate
/// pair costs the detection pass about 8 % more instructions in its candidate loop.
template <bool kRepresented, class Sink>
[[gnu::always_inline]] inline void visit_sub_pairs_of(const Topology& topo, const CollisionPrimitives& prims, Index p,
                                                      Index q, Sink& sink) {
  PrimitiveKind kp = prims.kind(p), kq = prims.kind(q);
  if (kp > kq) {
    std::swap(p, q);
    std::swap(kp, kq);
  }
  const Index a = prims.element(p), b = prims.element(q);
  auto owns = [](std::uint8_t mask, int bit) { return !kRepresented || (mask >> bit & 1); };
  if (kp == PrimitiveKind::triangle) {
    const Vec3i& fa = topo.faces[a];
    const std::uint8_t own_a = prims.face_owns[a];
    if (kq == PrimitiveKind::triangle) {
      if (prims.face_no_self[a] && topo.face_object[a] == topo.face_object[b]) return;
      const Vec3i& fb = topo.faces[b];
      const std::uint8_t own_b = prims.face_owns[b];
      for (int k = 0; k < 3; ++k)
        if (owns(own_a, k) && !has_vertex(fb, fa[k])) sink.vf(fa[k], b);
      for (int k = 0; k < 3; ++k)
        if (owns(own_b, k) && !has_vertex(fa, fb[k])) sink.vf(fb[k], a);
      for (int k = 0; k < 3; ++k) {
        if (!owns(own_a, 3 + k)) continue;
        const Index ea = topo.face_edges[a][k];
        for (int l = 0; l < 3; ++l) {
          if (!owns(own_b, 3 + l)) continue;
          const Index eb = topo.face_edges[b][l];
          if (!share_vertex(topo.edges[ea], topo.edges[eb])) sink.ee(ea, eb);
        }
      }
    } else if (kq == PrimitiveKind::edge) {
      const Vec2i& seg = topo.edges[b];
      const std::uint8_t own_s = prims.segment_owns[static_cast<size_t>(q - prims.num_triangles)];
      for (int k = 0; k < 2; ++k)
        if (owns(own_s, k) && !has_vertex(fa, seg[k])) sink.vf(seg[k], a);
      for (int k = 0; k < 3; ++k) {
        if (!owns(own_a, 3 + k)) continue;
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

/// The represented sub-pairs of (p, q): each sub-pair of the scene once over all primitive pairs.
template <class Sink>
[[gnu::always_inline]] inline void visit_sub_pairs(const Topology& topo, const CollisionPrimitives& prims, Index p,
                                                   Index q, Sink& sink) {
  visit_sub_pairs_of<true>(topo, prims, p, q, sink);
}

/// Closest points of sub-pairs in canonical orientation (ee and vv: lower id on side A, so the
/// result does not depend on which primitive came first), the one implementation behind every
/// pass. Per sub-pair: box pre-check against policy.pair_reach(), policy.admit() (the exclusion
/// look-up: false skips, else the slot), then the *_eval part, which a pass over the kept list
/// calls directly: with Policy::kCullFar the separating-axis bounds of distance.hpp, then the
/// distance kernel, policy.accept() (distance or negative) and policy.emit().
///
/// `Policy` provides: pair_reach(kind, verts) (m: the pre-filters' range for this sub-pair);
/// bool admit(kind, a, b, Index& slot);
/// double accept(kind, a, b, slot, verts, dist_sq); emit(kind, a, b, slot, verts, weights, pa, pb, dist);
/// and static constexpr bool kCullFar. verts: side A then side B (unused -1); weights positive on A,
/// negative on B (ContactPair::w). kCullFar is off for the initial configuration: near the reach
/// at coordinates far from the origin the bounds can settle a pair the kernel would place inside
/// it (distance.hpp), and the initial pass must keep exactly the kernel's answer.
template <class Policy>
struct ClosestPoints {
  const Topology& topo;
  const Positions& x;
  Policy policy;  ///< by value: its fields then sit in the sink, one load nearer than a reference

  void vf(Index v, Index f) {
    const Vec3& p = x[v];
    const Vec3i& t = topo.faces[f];
    const Vec3 &a = x[t[0]], &b = x[t[1]], &d = x[t[2]];
    const Vec3 lo = a.cwiseMin(b).cwiseMin(d), hi = a.cwiseMax(b).cwiseMax(d);
    if (!boxes_within(p, p, lo, hi, policy.pair_reach(ContactKind::vf, {v, t[0], t[1], t[2]}))) return;
    Index slot;
    if (policy.admit(ContactKind::vf, v, f, slot)) vf_eval(v, f, slot);
  }
  void vf_eval(Index v, Index f, Index slot) {
    const Vec3& p = x[v];
    const Vec3i& t = topo.faces[f];
    const std::array<Index, 4> verts{v, t[0], t[1], t[2]};
    if constexpr (Policy::kCullFar)
      if (point_triangle_apart_along_centres(p, x[t[0]], x[t[1]], x[t[2]],
                                             square(policy.pair_reach(ContactKind::vf, verts))))
        return;
    const PointTriangleResult r = point_triangle(p, x[t[0]], x[t[1]], x[t[2]]);
    const double dist = policy.accept(ContactKind::vf, v, f, slot, verts, r.distance_sq);
    if (dist < 0.0) return;
    policy.emit(ContactKind::vf, v, f, slot, verts, {1.0, -r.bary[0], -r.bary[1], -r.bary[2]}, p, r.closest, dist);
  }
  void ee(Index e0, Index e1) {
    if (e0 > e1) std::swap(e0, e1);
    const Vec2i &ea = topo.edges[e0], &eb = topo.edges[e1];
    const Vec3 &a0 = x[ea[0]], &a1 = x[ea[1]], &b0 = x[eb[0]], &b1 = x[eb[1]];
    const double reach = policy.pair_reach(ContactKind::ee, {ea[0], ea[1], eb[0], eb[1]});
    if (!boxes_within(a0.cwiseMin(a1), a0.cwiseMax(a1), b0.cwiseMin(b1), b0.cwiseMax(b1), reach)) return;
    Index slot;
    if (policy.admit(ContactKind::ee, e0, e1, slot)) ee_eval(e0, e1, slot);
  }
  void ee_eval(Index e0, Index e1, Index slot) {
    const Vec2i &ea = topo.edges[e0], &eb = topo.edges[e1];
    const Vec3 &a0 = x[ea[0]], &a1 = x[ea[1]], &b0 = x[eb[0]], &b1 = x[eb[1]];
    const std::array<Index, 4> verts{ea[0], ea[1], eb[0], eb[1]};
    if constexpr (Policy::kCullFar) {
      const double reach_sq = square(policy.pair_reach(ContactKind::ee, verts));
      if (segments_apart_along_centres(a0, a1, b0, b1, reach_sq)) return;
      if (segments_certainly_apart(a0, a1, b0, b1, reach_sq)) return;
    }
    const EdgeEdgeResult r = edge_edge(a0, a1, b0, b1);
    const double dist = policy.accept(ContactKind::ee, e0, e1, slot, verts, r.distance_sq);
    if (dist < 0.0) return;
    policy.emit(ContactKind::ee, e0, e1, slot, verts, {1.0 - r.s, r.s, -(1.0 - r.t), -r.t}, r.pa, r.pb, dist);
  }
  void ve(Index v, Index e) {
    const Vec3& p = x[v];
    const Vec2i& s = topo.edges[e];
    const Vec3 &a = x[s[0]], &b = x[s[1]];
    if (!boxes_within(p, p, a.cwiseMin(b), a.cwiseMax(b), policy.pair_reach(ContactKind::ve, {v, s[0], s[1], -1})))
      return;
    Index slot;
    if (policy.admit(ContactKind::ve, v, e, slot)) ve_eval(v, e, slot);
  }
  void ve_eval(Index v, Index e, Index slot) {
    const Vec3& p = x[v];
    const Vec2i& s = topo.edges[e];
    const std::array<Index, 4> verts{v, s[0], s[1], -1};
    if constexpr (Policy::kCullFar)
      if (point_segment_apart_along_centres(p, x[s[0]], x[s[1]], square(policy.pair_reach(ContactKind::ve, verts))))
        return;
    const PointEdgeResult r = point_edge(p, x[s[0]], x[s[1]]);
    const double dist = policy.accept(ContactKind::ve, v, e, slot, verts, r.distance_sq);
    if (dist < 0.0) return;
    policy.emit(ContactKind::ve, v, e, slot, verts, {1.0, -(1.0 - r.t), -r.t, 0.0}, p, r.closest, dist);
  }
  void vv(Index v0, Index v1) {
    if (v0 > v1) std::swap(v0, v1);
    const Vec3 &p = x[v0], &q = x[v1];
    if (!boxes_within(p, p, q, q, policy.pair_reach(ContactKind::vv, {v0, v1, -1, -1}))) return;
    Index slot;
    if (policy.admit(ContactKind::vv, v0, v1, slot)) vv_eval(v0, v1, slot);
  }
  void vv_eval(Index v0, Index v1, Index slot) {
    const Vec3 &p = x[v0], &q = x[v1];
    const std::array<Index, 4> verts{v0, v1, -1, -1};
    const double dist = policy.accept(ContactKind::vv, v0, v1, slot, verts, point_point_distance_sq(p, q));
    if (dist < 0.0) return;
    policy.emit(ContactKind::vv, v0, v1, slot, verts, {1.0, -1.0, 0.0, 0.0}, p, q, dist);
  }
};

/// Side A's vertex count of a sub-pair kind (ContactPair::side_a) and its vertex count (size).
inline int side_a_size(ContactKind kind) { return kind == ContactKind::ee ? 2 : 1; }
inline int sub_pair_size(ContactKind kind) {
  return kind == ContactKind::vf || kind == ContactKind::ee ? 4 : (kind == ContactKind::ve ? 3 : 2);
}

/// Squared distance (m²) of the sub-pair with this sub_pair_key at positions x: the kernels alone,
/// without pre-checks, so a NaN position gives NaN.
double sub_pair_distance_sq(const Topology& topo, const Positions& x, std::uint64_t key);

}  // namespace ccfr::detail
