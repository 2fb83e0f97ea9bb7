#include "initial_proximity.hpp"

#include <atomic>
#include <cmath>
#include <limits>
#include <string>

#include "ccfr/core/error.hpp"
#include "ccfr/core/log.hpp"
#include "ccfr/core/parallel.hpp"
#include "ccfr/geometry/adjacency.hpp"
#include "ccfr/geometry_exact/predicates.hpp"
#include "sub_pairs.hpp"

namespace ccfr::detail {

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

double InitialPairs::offset(ContactKind kind, Index a, Index b, double xi) const {
  const Index slot = table.find(kind, a, b);
  return slot >= 0 ? reduced_offset[static_cast<size_t>(slot)] : xi;
}

void InitialPairs::raise(const Topology& topo, const Positions& x, double xi) {
  parallel_for(
      static_cast<Index>(active.size()),
      [&](Index b, Index e) {
        for (Index i = b; i < e; ++i) {
          const Index slot = active[i];
          const double d = std::sqrt(sub_pair_distance_sq(topo, x, reduced_key[slot]));
          const double raised = std::min(xi, (1.0 - kInitialOffsetMargin) * d);
          if (raised > reduced_offset[slot]) reduced_offset[slot] = raised;  // NaN compares false: kept
        }
      },
      1024);
  active.erase(std::remove_if(active.begin(), active.end(), [&](Index slot) { return !(reduced_offset[slot] < xi); }),
               active.end());
}

void InitialPairs::mark(Mark& m) const {
  m.active = active;
  m.offset.resize(active.size());
  for (size_t i = 0; i < active.size(); ++i) m.offset[i] = reduced_offset[static_cast<size_t>(active[i])];
}

void InitialPairs::roll_back(const Mark& m) {
  // raise() changes only active slots and removes slots from the list, never adds: the slots
  // outside the mark's list held their values since.
  for (size_t i = 0; i < m.active.size(); ++i) reduced_offset[static_cast<size_t>(m.active[i])] = m.offset[i];
  active = m.active;
}

void InitialPairs::restore(std::span<const double> offsets, double xi) {
  if (offsets.size() != reduced_offset.size())
    throw Error("collision state: " + std::to_string(offsets.size()) + " reduced offsets given, this scene has " +
                std::to_string(reduced_offset.size()) + " sub-pairs that start closer than the offset");
  for (size_t i = 0; i < offsets.size(); ++i)
    if (!std::isfinite(offsets[i]) || offsets[i] < reduced_offset[i] || offsets[i] > xi)
      throw Error(
          ccfr::format("collision state: reduced offset {} is {:.17g}, outside [{:.17g}, {:.17g}] (its initial "
                       "value and the offset)",
                       i, offsets[i], reduced_offset[i], xi));
  for (size_t i = 0; i < offsets.size(); ++i)
    if (reduced_fixed[i] && offsets[i] != reduced_offset[i])
      throw Error(
          ccfr::format("collision state: reduced offset {} belongs to an adjacent sub-pair and is fixed at "
                       "{:.17g}, got {:.17g}",
                       i, reduced_offset[i], offsets[i]));
  reduced_offset.assign(offsets.begin(), offsets.end());
  // Exactly the slots raise() would have kept: those still below ξ, ascending, except the
  // adjacent ones, which never rise.
  active.clear();
  for (size_t i = 0; i < reduced_offset.size(); ++i) {
    if (reduced_offset[i] < xi && !reduced_fixed[i]) active.push_back(static_cast<Index>(i));
  }
}

namespace {

/// A sub-pair closer than ξ + δ in the initial configuration; distance in m.
struct CloseSubPair {
  std::uint64_t key;
  double distance;
  std::array<Index, 2> va;  ///< side A's vertices (-1 unused)
  std::array<Index, 3> vb;  ///< side B's vertices (-1 unused)
};

/// ClosestPoints policy of the initial pass: every sub-pair closer than `reach`, obstacles
/// included, degenerate distances included, nothing excluded yet.
struct ClosePolicy {
  static constexpr bool kCullFar = false;  // keep exactly the kernel's answer (sub_pairs.hpp)
  double reach_m;
  std::vector<CloseSubPair>& out;

  double pair_reach(ContactKind, const std::array<Index, 4>&) const { return reach_m; }
  bool admit(ContactKind, Index, Index, Index& slot) const {
    slot = InitialPairTable::kAbsent;
    return true;
  }
  double accept(ContactKind, Index, Index, Index, const std::array<Index, 4>&, double dist_sq) const {
    return dist_sq < reach_m * reach_m ? std::sqrt(dist_sq) : -1.0;
  }
  void emit(ContactKind kind, Index a, Index b, Index, const std::array<Index, 4>& v, const std::array<double, 4>&,
            const Vec3&, const Vec3&, double dist) {
    CloseSubPair& s = out.emplace_back();
    s.key = sub_pair_key(kind, a, b);
    s.distance = dist;
    const int na = side_a_size(kind);
    s.va = {v[0], na > 1 ? v[1] : -1};
    s.vb = {v[na], v[na + 1], na + 2 < 4 ? v[na + 2] : -1};
  }
};

/// Per primitive: all of its vertices belong to obstacles. Obstacles are scripted, so nothing
/// between two such primitives is ever constrained and the broad phase leaves their pairs out.
std::vector<std::uint8_t> obstacle_primitives(const Topology& topo, const CollisionPrimitives& prims) {
  std::vector<std::uint8_t> flags(static_cast<size_t>(prims.size()), 0);
  auto obstacle = [&](Index v) { return topo.objects[topo.vertex_object[v]].kind == ObjectKind::obstacle; };
  for (Index p = 0; p < prims.size(); ++p) {
    const Index e = prims.element(p);
    switch (prims.kind(p)) {
      case PrimitiveKind::triangle:
        flags[p] = obstacle(topo.faces[e][0]) && obstacle(topo.faces[e][1]) && obstacle(topo.faces[e][2]);
        break;
      case PrimitiveKind::edge:
        flags[p] = obstacle(topo.edges[e][0]) && obstacle(topo.edges[e][1]);
        break;
      case PrimitiveKind::point:
        flags[p] = obstacle(e);
        break;
    }
  }
  return flags;
}

/// Primitive pairs that cross in the initial configuration and their sub-pairs' keys.
struct Crossings {
  Index pairs = 0;
  std::vector<std::uint64_t> keys;  ///< sorted, unique
};

/// Every sub-pair given, as its key (all of a crossing pair's, not only the represented ones).
struct KeySink {
  std::vector<std::uint64_t>& keys;
  void vf(Index v, Index f) { keys.push_back(sub_pair_key(ContactKind::vf, v, f)); }
  void ee(Index a, Index b) { keys.push_back(sub_pair_key(ContactKind::ee, std::min(a, b), std::max(a, b))); }
  void ve(Index v, Index e) { keys.push_back(sub_pair_key(ContactKind::ve, v, e)); }
  void vv(Index a, Index b) { keys.push_back(sub_pair_key(ContactKind::vv, std::min(a, b), std::max(a, b))); }
};

/// Whether the triangle-triangle or triangle-segment pair (p, q) crosses at x (exact predicates;
/// false for other kinds and for two triangles of one rigid or obstacle object).
bool primitives_cross(const Topology& topo, const CollisionPrimitives& prims, const Positions& x, Index p, Index q) {
  PrimitiveKind kp = prims.kind(p), kq = prims.kind(q);
  if (kp > kq) {
    std::swap(p, q);
    std::swap(kp, kq);
  }
  if (kp != PrimitiveKind::triangle || kq == PrimitiveKind::point) return false;
  auto tri_crossed_by = [&](const Vec3i& f, const Vec2i& e) {
    return exact::segment_crosses_triangle(x[e[0]], x[e[1]], x[f[0]], x[f[1]], x[f[2]]);
  };
  const Vec3i& fa = topo.faces[p];
  if (kq == PrimitiveKind::edge) return tri_crossed_by(fa, topo.edges[prims.element(q)]);
  if (prims.face_no_self[p] && topo.face_object[p] == topo.face_object[q]) return false;
  const Vec3i& fb = topo.faces[q];
  for (int k = 0; k < 3; ++k)
    if (tri_crossed_by(fb, topo.edges[topo.face_edges[p][k]]) || tri_crossed_by(fa, topo.edges[topo.face_edges[q][k]]))
      return true;
  return false;
}

/// Crossings (paper §4.1): every sub-pair of a crossing primitive pair is excluded for the run,
/// since its closest points would give an inverted normal.
Crossings find_crossings(const Topology& topo, const CollisionPrimitives& prims,
                         const std::vector<IndexPair>& candidates, const Positions& initial) {
  const Index n = static_cast<Index>(candidates.size());
  const Index chunks = default_chunk_count(n);
  std::vector<std::vector<std::uint64_t>> keys(static_cast<size_t>(chunks));
  std::atomic<Index> crossing{0};
  parallel_chunks(n, chunks, [&](Index chunk, Index begin, Index end) {
    KeySink sink{keys[chunk]};
    Index local = 0;
    for (Index i = begin; i < end; ++i) {
      const auto [p, q] = candidates[i];
      if (!primitives_cross(topo, prims, initial, p, q)) continue;
      visit_sub_pairs_of<false>(topo, prims, p, q, sink);
      ++local;
    }
    crossing += local;
  });
  Crossings c;
  c.pairs = crossing.load();
  for (const auto& k : keys) c.keys.insert(c.keys.end(), k.begin(), k.end());
  std::sort(c.keys.begin(), c.keys.end());
  c.keys.erase(std::unique(c.keys.begin(), c.keys.end()), c.keys.end());
  return c;
}

/// Close pairs: the sub-pairs closer than `reach` (ξ + δ), in key order so that slots do not
/// depend on the chunking.
std::vector<CloseSubPair> find_close_sub_pairs(const Topology& topo, const CollisionPrimitives& prims,
                                               const std::vector<IndexPair>& candidates, const Positions& initial,
                                               double reach) {
  const Index n = static_cast<Index>(candidates.size());
  const Index chunks = default_chunk_count(n);
  std::vector<std::vector<CloseSubPair>> close(static_cast<size_t>(chunks));
  parallel_chunks(n, chunks, [&](Index chunk, Index begin, Index end) {
    ClosestPoints<ClosePolicy> cp{topo, initial, ClosePolicy{reach, close[chunk]}};
    for (Index i = begin; i < end; ++i) visit_sub_pairs(topo, prims, candidates[i].first, candidates[i].second, cp);
  });
  std::vector<CloseSubPair> all;
  for (const auto& c : close) all.insert(all.end(), c.begin(), c.end());
  std::sort(all.begin(), all.end(), [](const CloseSubPair& x, const CloseSubPair& y) { return x.key < y.key; });
  all.erase(
      std::unique(all.begin(), all.end(), [](const CloseSubPair& x, const CloseSubPair& y) { return x.key == y.key; }),
      all.end());
  return all;
}

/// Calls f(edge, length) for every edge of a deformable object (not obstacle, not rigid) at x.
template <class F>
void for_each_deformable_edge(const Topology& topo, const Positions& x, F&& f) {
  for (Index e = 0; e < topo.num_edges(); ++e) {
    const ObjectKind k = topo.objects[topo.edge_object[e]].kind;
    if (k == ObjectKind::obstacle || k == ObjectKind::rigid) continue;
    f(e, (x[topo.edges[e][1]] - x[topo.edges[e][0]]).norm());
  }
}

/// Adjacency of close pairs: `offset` for those closer than ξ (path ≤ kAdjacencyRadiusInOffsets ξ
/// along the mesh), `band` for those only in the repulsion band (ξ ≤ d₀ < ξ + δ; path ≤
/// kAdjacencyRadiusInOffsets (ξ + δ) plus the longest deformable edge: on a surface whose edges
/// are longer than 2ξ a face one ring away is already further than 2ξ along the edges). Built only
/// around side A's vertices of the pairs each serves.
struct Neighbourhoods {
  TopologicalAdjacency offset, band;
};

Neighbourhoods find_neighbourhoods(const Topology& topo, const Positions& initial,
                                   const std::vector<CloseSubPair>& close, const ContactModel& params) {
  // Side A's vertices of the close pairs, or of those only in the band; false if there are none.
  std::vector<std::uint8_t> sources;
  auto mark_sources = [&](bool band_only) {
    sources.assign(static_cast<size_t>(topo.num_vertices()), 0);
    bool any = false;
    for (const CloseSubPair& c : close)
      if (!band_only || !(c.distance < params.offset))
        for (Index v : c.va)
          if (v >= 0) sources[v] = 1, any = true;
    return any;
  };
  Neighbourhoods nb;
  if (mark_sources(false))
    nb.offset = TopologicalAdjacency(topo, initial, kAdjacencyRadiusInOffsets * params.offset, sources);
  if (mark_sources(true)) {
    double longest = 0.0;
    for_each_deformable_edge(topo, initial, [&](Index, double len) { longest = std::max(longest, len); });
    nb.band = TopologicalAdjacency(
        topo, initial, kAdjacencyRadiusInOffsets * (params.offset + params.repulsion_range) + longest, sources);
  }
  return nb;
}

/// Gives every close pair that keeps contact a slot: closer than ξ (reduced offset (1 − m) d₀,
/// fixed for mesh neighbours), or a mesh neighbour inside the band (offset ξ, no repulsion). Skips
/// crossing sub-pairs and pairs with obstacles on both sides. Appends (key, slot) to `entries`.
void assign_slots(const Topology& topo, const std::vector<CloseSubPair>& close, const Crossings& crossings,
                  const Neighbourhoods& nb, double xi, InitialPairs& out,
                  std::vector<std::pair<std::uint64_t, Index>>& entries) {
  auto on_obstacle = [&](std::span<const Index> vs) {
    for (Index v : vs)
      if (topo.objects[topo.vertex_object[v]].kind != ObjectKind::obstacle) return false;
    return true;
  };
  Index band_neighbours = 0;
  for (const CloseSubPair& c : close) {
    if (std::binary_search(crossings.keys.begin(), crossings.keys.end(), c.key)) continue;
    const std::span<const Index> va(c.va.data(), c.va[1] >= 0 ? 2 : 1);
    const std::span<const Index> vb(c.vb.data(), c.vb[2] >= 0 ? 3 : (c.vb[1] >= 0 ? 2 : 1));
    if (on_obstacle(va) && on_obstacle(vb)) continue;  // scripted on both sides: never constrained
    // Neighbours keep contact at their rest distance less the margin, never raised: a raised
    // offset would stiffen the material, and an excluded pair could intersect unseen.
    const bool close_to_offset = c.distance < xi;
    const bool adjacent = close_to_offset ? nb.offset.adjacent(va, vb) : nb.band.adjacent(va, vb);
    if (!close_to_offset && !adjacent) continue;  // only in the repulsion band: an ordinary pair
    entries.emplace_back(c.key, static_cast<Index>(out.reduced_key.size()));
    out.reduced_key.push_back(c.key);
    out.reduced_offset.push_back(close_to_offset ? (1.0 - kInitialOffsetMargin) * c.distance : xi);
    out.reduced_fixed.push_back(adjacent ? 1 : 0);
    if (adjacent && close_to_offset) ++out.proximity.adjacent_kept;
    if (!close_to_offset) ++band_neighbours;
  }
  InitialProximity& ip = out.proximity;
  ip.reduced_offset = static_cast<Index>(out.reduced_key.size()) - ip.adjacent_kept - band_neighbours;
  ip.min_reduced_offset = std::numeric_limits<double>::infinity();
  for (size_t i = 0; i < out.reduced_offset.size(); ++i)
    if (!out.reduced_fixed[i]) ip.min_reduced_offset = std::min(ip.min_reduced_offset, out.reduced_offset[i]);
  if (ip.reduced_offset == 0) ip.min_reduced_offset = 0.0;
  for (size_t i = 0; i < out.reduced_key.size(); ++i)
    if (!out.reduced_fixed[i]) out.active.push_back(static_cast<Index>(i));
}

/// Warnings: the counts (info), reduced offsets, neighbours on a mesh finer than ξ (naming the
/// object with the shortest deformable edge, or none if shortest_object < 0), crossing pairs.
void log_initial_proximity(const Topology& topo, const CollisionPrimitives& prims, const InitialProximity& ip,
                           Index closer_than_offset, Index shortest_object, double xi) {
  log::info(
      "collision: {} primitives; initial configuration: {} sub-pairs closer than the offset {} ({} adjacent, "
      "kept with a fixed reduced offset; {} others kept with a rising reduced offset), {} intersecting primitive "
      "pairs ({} sub-pairs excluded)",
      prims.size(), closer_than_offset, xi, ip.adjacent_kept, ip.reduced_offset, ip.intersecting_pairs,
      ip.intersecting_excluded);
  if (ip.reduced_offset > 0)
    log::warn(
        "collision: {} sub-pairs that are not neighbours on a mesh start closer than the offset {} (closest "
        "{:.4g}); they keep contact with their initial distance less {:.0f}% as offset, raised toward {} as they "
        "separate",
        ip.reduced_offset, xi, ip.min_reduced_offset / (1.0 - kInitialOffsetMargin), 100.0 * kInitialOffsetMargin, xi);
  if (ip.adjacent_kept > 0 && shortest_object >= 0)
    log::warn(
        "collision: the offset {} is large against the mesh (shortest edge {:.4g} in object '{}'): {} sub-pairs "
        "joined by a path of at most {:.4g} along the mesh start closer than the offset; they keep their rest "
        "distance less {:.0f}% as offset for the run, so the surface resists being compressed more than that "
        "there (docs/choosing-parameters.md, \"Meshes finer than xi\")",
        xi, ip.shortest_edge, topo.objects[shortest_object].name, ip.adjacent_kept, kAdjacencyRadiusInOffsets * xi,
        100.0 * kInitialOffsetMargin);
  if (ip.intersecting_pairs > 0)
    log::warn(
        "collision: {} primitive pairs intersect in the initial configuration; their {} sub-pairs are excluded "
        "for the run",
        ip.intersecting_pairs, ip.intersecting_excluded);
}

}  // namespace

InitialPairs find_initial_pairs(const Topology& topo, const CollisionPrimitives& prims, BroadPhase& broad,
                                const Positions& initial, const ContactModel& params,
                                std::vector<IndexPair>& candidates) {
  broad.set_fixed(obstacle_primitives(topo, prims));
  broad.query_pairs(candidates);
  broad.set_fixed({});
  const Crossings crossings = find_crossings(topo, prims, candidates, initial);
  // Within ξ + δ: mesh neighbours inside the repulsion band at rest are flagged too (no repulsion).
  const std::vector<CloseSubPair> close =
      find_close_sub_pairs(topo, prims, candidates, initial, params.offset + params.repulsion_range);
  InitialPairs out;
  out.proximity.intersecting_pairs = crossings.pairs;
  out.proximity.intersecting_excluded = static_cast<Index>(crossings.keys.size());
  std::vector<std::pair<std::uint64_t, Index>> entries;
  for (std::uint64_t k : crossings.keys) entries.emplace_back(k, InitialPairTable::kExcluded);
  assign_slots(topo, close, crossings, find_neighbourhoods(topo, initial, close, params), params.offset, out, entries);
  out.table.assign(std::move(entries));

  // Shortest deformable edge, for the warning on ξ against the mesh resolution.
  InitialProximity& ip = out.proximity;
  ip.shortest_edge = std::numeric_limits<double>::infinity();
  Index shortest_object = -1;
  for_each_deformable_edge(topo, initial, [&](Index e, double len) {
    if (len < ip.shortest_edge) ip.shortest_edge = len, shortest_object = topo.edge_object[e];
  });
  const auto closer =
      std::count_if(close.begin(), close.end(), [&](const CloseSubPair& c) { return c.distance < params.offset; });
  log_initial_proximity(topo, prims, ip, static_cast<Index>(closer), shortest_object, params.offset);
  return out;
}

}  // namespace ccfr::detail
