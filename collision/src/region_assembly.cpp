#include "region_assembly.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <optional>
#include <string>

#include "ccfr/core/block_cursors.hpp"
#include "ccfr/core/buffers.hpp"
#include "ccfr/core/error.hpp"
#include "ccfr/core/parallel.hpp"
#include "ccfr/geometry/distance.hpp"

namespace ccfr {

namespace {
/// Share of side A of a contact's gap (design clarification 4): \f$ s_A = w_A / (w_A + w_B) \f$
/// with \f$ w_{side} = \sum_i \beta_i w_i \f$ (Alg. NarrowPhase lines 8, 23-24), so s_A + s_B = 1.
/// Then for displacements inside all half-spaces every vertex of A stays at
/// n·x ≥ n·x_A − s_A φ and every vertex of B at n·x ≤ n·x_B + s_B φ (the closest points are
/// extreme along n over each primitive): the plane in between keeps the primitives
/// ≥ ‖x_A − x_B‖ − φ = ξ apart. Any split summing to 1 keeps this argument.
///
/// Where immovable vertices hold part β_fixed of a side's closest point, that part counts with
/// the mean inverse mass of the side's movable vertices, since the side can still turn about its
/// pinned point (the paper's weights alone give such a side s = 0, no room at all):
/// \f$ w_{side} = \sum_{i\,\mathrm{movable}} \beta_i w_i + \beta_{fixed}\,\bar w_{movable} \f$.
/// A side without immovable vertices keeps the paper's weight; both closest points on immovable
/// vertices split the gap by the sides' movable means (½–½ for equal masses).
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

namespace detail {
namespace {

/// The record of one contact: (n, s_A G, s_B G) with G = φ − K_A − K_B, K the largest approach
/// along n of a side's kinematic vertices over the coming iteration (their steps are zero for
/// dynamic vertices, so the sum runs over all of c's vertices). The closest points are separated
/// by the plane normal to n and every vertex of a side must stay behind it, so a kinematic side is
/// bounded by its worst-moving vertex (a rotating handle's far corner approaches faster than its
/// closest point). d stays negative for a pair already inside its offset (clarification 7).
RegionRecord contact_record(const ContactPair& c, const Positions& x, std::span<const double> inv_mass,
                            std::span<const Vec3> kinematic_step) {
  double gap = c.distance - c.offset;
  if (!kinematic_step.empty()) {
    const int na = c.side_a();
    double k_a = 0.0, k_b = 0.0;
    for (int k = 0; k < c.size(); ++k) {
      const double along = c.n.dot(kinematic_step[c.v[k]]);  // zero for dynamic vertices
      if (k < na)
        k_a = std::max(k_a, -along);
      else
        k_b = std::max(k_b, along);
    }
    gap -= k_a + k_b;
  }
  const double s_a = share_a(c, inv_mass), s_b = 1.0 - s_a;
  if (gap < 0.0 && split_cannot_close(c, inv_mass))
    if (const auto mixed = mixed_pair_record(c, x, inv_mass, kinematic_step, s_a)) return *mixed;
  return {c.n, {s_a * gap, s_b * gap}};
}

/// Counts, per block of consecutive contacts, the planes of every vertex (into block_cursor).
void count_planes(Index nv, std::span<const double> inv_mass, std::span<const ContactPair> contacts, Index blocks,
                  std::vector<Index>& block_cursor) {
  for_cursor_blocks(static_cast<Index>(contacts.size()), blocks, [&](Index b, Index begin, Index end) {
    Index* count = block_cursor.data() + static_cast<size_t>(b) * nv;
    std::fill(count, count + nv, 0);
    for (Index ci = begin; ci < end; ++ci) {
      const ContactPair& c = contacts[static_cast<size_t>(ci)];
      for (int k = 0; k < c.size(); ++k)
        if (inv_mass[c.v[k]] > 0.0) ++count[c.v[k]];
    }
  });
}

/// Writes the contacts' records and plane references, each block at its own cursors.
void write_planes(Index nv, const Positions& x, std::span<const double> inv_mass, std::span<const Vec3> kinematic_step,
                  std::span<const ContactPair> contacts, Index blocks, AssemblyBuffers& work, RegionSet& regions) {
  for_cursor_blocks(static_cast<Index>(contacts.size()), blocks, [&](Index b, Index begin, Index end) {
    Index* cursor = work.block_cursor.data() + static_cast<size_t>(b) * nv;
    for (Index ci = begin; ci < end; ++ci) {
      const ContactPair& c = contacts[static_cast<size_t>(ci)];
      const Index slot0 = 4 * ci;
      regions.records[static_cast<size_t>(ci)] = contact_record(c, x, inv_mass, kinematic_step);
      // One record per contact; each movable vertex's slot refers to it and its side.
      const std::uint32_t ref = 2 * static_cast<std::uint32_t>(ci);
      const int na = c.side_a();
      for (int k = 0; k < c.size(); ++k) {
        const Index v = c.v[k];
        if (!(inv_mass[v] > 0.0)) continue;
        if (work.record_sources) work.plane_sources[static_cast<size_t>(cursor[v])] = slot0 + k;
        regions.refs[static_cast<size_t>(cursor[v]++)] = ref + (k < na ? 0u : 1u);
      }
    }
  });
}

}  // namespace

// The CSR is filled in parallel without sorting: the contacts are split into at most 32 fixed
// blocks of consecutive contacts, each block counts its planes per vertex, and prefix sums over
// (vertex, block) give every block its own write cursor per vertex.
void assemble_regions(Index nv, const Positions& x, std::span<const double> inv_mass,
                      std::span<const Vec3> kinematic_step, std::span<const ContactPair> contacts,
                      AssemblyBuffers& work, RegionSet& regions) {
  regions.row_start.assign(static_cast<size_t>(nv) + 1, 0);
  if (contacts.size() > std::numeric_limits<std::uint32_t>::max() / 2)
    throw Error("CollisionDetector::detect: " + std::to_string(contacts.size()) +
                " contacts exceed the region's 32-bit plane references");
  resize_for_overwrite(regions.records, contacts.size(), work.spare_records);  // every record is written below
  if (contacts.empty()) {
    resize_for_overwrite(regions.refs, 0, work.spare_refs);
    work.plane_sources.clear();
    return;
  }
  // Blocks x vertices cursors cost as much as the scatter they split once the contacts are few (a
  // pass that moves a handful of vertices): about 1,024 contacts per block, at most 32.
  const Index blocks = cursor_blocks(static_cast<Index>(contacts.size()));
  work.block_cursor.resize(static_cast<size_t>(blocks) * nv);
  count_planes(nv, inv_mass, contacts, blocks, work.block_cursor);
  counts_to_block_cursors(nv, blocks, work.block_cursor, regions.row_start);
  // Every entry is written below: resizing without clearing first skips zero-filling them.
  resize_for_overwrite(regions.refs, static_cast<size_t>(regions.row_start.back()), work.spare_refs);
  resize_for_overwrite(work.plane_sources, work.record_sources ? regions.refs.size() : 0);
  write_planes(nv, x, inv_mass, kinematic_step, contacts, blocks, work, regions);
}

}  // namespace detail
}  // namespace ccfr
