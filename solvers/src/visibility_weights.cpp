#include "ccfr/solvers/contact_response.hpp"

#include <algorithm>
#include <atomic>
#include <bit>
#include <cmath>
#include <cstdint>
#include <string>

#include "ccfr/core/block_cursors.hpp"
#include "ccfr/core/buffers.hpp"
#include "ccfr/core/error.hpp"
#include "ccfr/core/parallel.hpp"

namespace ccfr {

namespace {
struct GroupScratch {
  std::vector<double> gap;  ///< the group's gaps, in group order
  std::vector<Index> window;
  std::vector<double> window_gap;
  std::vector<std::uint32_t> by_gap;  ///< window positions, nearest first
  std::vector<std::uint64_t> nearer;  ///< bit p: window position p is nearer than the current one
};

/// w_i = Π_j (1 − S((g_i − g_j) / width)) over the window's j with g_j < g_i, the factors taken in
/// window order and the product stopped once it is 0. Small windows scan every j for each i.
void weigh_window(std::span<const Index> window, std::span<const double> gap, double width, std::vector<double>& vis,
                  GroupScratch& scratch) {
  const size_t k = window.size();
  auto factor = [&](double gi, double gj) { return 1.0 - smoothstep((gi - gj) / width); };
  if (k <= 4) {
    for (size_t i = 0; i < k; ++i) {
      const double gi = gap[i];
      double w = 1.0;
      for (size_t j = 0; j < k && w != 0.0; ++j)
        if (gap[j] < gi) w *= factor(gi, gap[j]);
      vis[window[i]] = w;
    }
    return;
  }
  // Larger windows visit only the nearer j: positions in increasing gap, each run of equal gaps
  // weighed against a bit set of the strictly nearer positions, read word by word in window order
  // (so the same factors in the same order as the scan: bit-identical), then added to it. A NaN
  // gap is never nearer than anything and has nothing nearer: weight 1.
  auto& order = scratch.by_gap;
  order.clear();
  for (size_t i = 0; i < k; ++i) {
    if (std::isnan(gap[i]))
      vis[window[i]] = 1.0;
    else
      order.push_back(static_cast<std::uint32_t>(i));
  }
  std::sort(order.begin(), order.end(), [&](std::uint32_t a, std::uint32_t b) { return gap[a] < gap[b]; });
  auto& nearer = scratch.nearer;
  nearer.assign((k + 63) / 64, 0);
  for (size_t r = 0; r < order.size();) {
    size_t e = r + 1;
    while (e < order.size() && gap[order[e]] == gap[order[r]]) ++e;
    for (size_t q = r; q < e; ++q) {
      const double gi = gap[order[q]];
      double w = 1.0;
      // Every factor lies in [0, 1] (S does for any t), so a product that reached 0 stays +0 over
      // the rest of its word: checking once a word gives the value of the scan that stops at 0.
      for (size_t word = 0; word < nearer.size() && w != 0.0; ++word)
        for (std::uint64_t bits = nearer[word]; bits != 0; bits &= bits - 1)
          w *= factor(gi, gap[64 * word + static_cast<size_t>(std::countr_zero(bits))]);
      vis[window[order[q]]] = w;
    }
    for (size_t q = r; q < e; ++q) nearer[order[q] / 64] |= std::uint64_t{1} << (order[q] % 64);
    r = e;
  }
}

/// The weights of one query vertex's contacts, `group` in increasing index order.
/// Only contacts j with d_c - δ_v < d_j < d_c attenuate c (S vanishes for d_j >= d_c), and any j
/// with d_j <= d_c - δ_v occludes c completely (S = 1). So within a group every contact at least
/// δ_v beyond the group's nearest has weight 0, and the product runs over the contacts inside
/// that window.
void weigh_group(std::span<const Index> group, std::span<const ContactPair> contacts, double width,
                 std::vector<double>& vis, GroupScratch& scratch) {
  if (group.size() < 2) return;
  auto& gap = scratch.gap;  // each 96-byte record is read once
  gap.resize(group.size());
  for (size_t i = 0; i < group.size(); ++i) gap[i] = contacts[group[i]].distance - contacts[group[i]].offset;
  const double nearest = *std::min_element(gap.begin(), gap.end());
  auto& window = scratch.window;
  auto& window_gap = scratch.window_gap;
  window.clear();
  window_gap.clear();
  for (size_t i = 0; i < group.size(); ++i) {
    if (const double g = gap[i]; g - nearest >= width) {
      vis[group[i]] = 0.0;
    } else {
      window.push_back(group[i]);
      window_gap.push_back(g);
    }
  }
  weigh_window(window, window_gap, width, vis, scratch);
}
}  // namespace

std::vector<double> visibility_weights(std::span<const ContactPair> contacts, double width) {
  std::vector<double> vis;
  VisibilityWorkspace ws;
  visibility_weights(contacts, width, vis, ws);
  return vis;
}

void visibility_weights(std::span<const ContactPair> contacts, double width, std::vector<double>& vis,
                        VisibilityWorkspace& ws) {
  const Index n = static_cast<Index>(contacts.size());
  vis.assign(static_cast<size_t>(n), 1.0);
  if (width <= 0.0 || n == 0) return;
  // Grouping by query vertex, in parallel: fixed blocks of consecutive contacts count their query
  // vertices, prefix sums over (vertex, block) give each block its own cursor per vertex, and each
  // block scatters its contacts. Every group thus lists its contacts in increasing index order, as
  // a serial counting sort would, for any thread count. (Serial, these three passes over the
  // 96-byte contact records were about 6 % of a soft-wire frame at one thread.) About 1,024
  // contacts per block, at most 32: the blocks x vertices cursors must not outweigh few contacts.
  const Index blocks = cursor_blocks(n);
  std::vector<Index> block_max(static_cast<size_t>(blocks), 0);
  for_cursor_blocks(n, blocks, [&](Index b, Index lo, Index hi) {
    Index m = 0;
    for (Index i = lo; i < hi; ++i) m = std::max(m, contacts[i].v[0]);
    block_max[b] = m;
  });
  const Index nq = *std::max_element(block_max.begin(), block_max.end()) + 1;  // query vertices 0..nq-1
  std::vector<Index>& cursor = ws.cursor;  // (block, vertex): a count, then the block's write cursor
  cursor.resize(static_cast<size_t>(blocks) * nq);
  for_cursor_blocks(n, blocks, [&](Index b, Index lo, Index hi) {
    Index* count = cursor.data() + static_cast<size_t>(b) * nq;
    std::fill(count, count + nq, 0);
    for (Index i = lo; i < hi; ++i) ++count[contacts[i].v[0]];
  });
  std::vector<Index>& start = ws.start;
  counts_to_block_cursors(nq, blocks, cursor, start);
  std::vector<Index>& order = ws.order;
  order.resize(static_cast<size_t>(n));
  for_cursor_blocks(n, blocks, [&](Index b, Index lo, Index hi) {
    Index* at = cursor.data() + static_cast<size_t>(b) * nq;
    for (Index i = lo; i < hi; ++i) order[at[contacts[i].v[0]]++] = i;
  });
  parallel_for(
      nq,
      [&](Index vb, Index ve) {
        GroupScratch scratch;
        for (Index v = vb; v < ve; ++v)
          weigh_group(std::span<const Index>(order).subspan(start[v], start[v + 1] - start[v]), contacts, width, vis,
                      scratch);
      },
      256);
}

void visibility_weights(std::span<const ContactPair> contacts, std::span<const Index> row_start,
                        std::span<const Index> slots, double width, std::vector<double>& vis, VisibilityWorkspace& ws,
                        std::span<const double> movable) {
  const Index n = static_cast<Index>(contacts.size());
  fill_parallel(vis, n, 1.0);
  if (width <= 0.0 || n == 0) return;
  if (row_start.empty() || static_cast<size_t>(row_start.back()) != slots.size())
    throw Error("visibility_weights: the incidence has " + std::to_string(slots.size()) +
                " slots, its row starts end at " +
                (row_start.empty() ? std::string("nothing") : std::to_string(row_start.back())));
  const Index nv = static_cast<Index>(row_start.size()) - 1;
  // Nothing movable (a pile of rigid bodies on an obstacle): apply() uses no weight.
  if (!movable.empty() && std::none_of(movable.begin(), movable.end(), [](double w) { return w > 0.0; })) return;
  // A listed vertex's slots of k = 0 are exactly its contacts as query vertex, in contact order:
  // its group, read without the three passes over the 96-byte records the grouping needs.
  std::atomic<Index> grouped{0};  // contacts in the listed groups: each is in one at most
  std::vector<std::uint8_t>& in_group = ws.grouped;
  fill_parallel(in_group, n, std::uint8_t{0});
  parallel_for(
      nv,
      [&](Index vb, Index ve) {
        GroupScratch scratch;
        std::vector<Index> group;
        Index local = 0;
        for (Index v = vb; v < ve; ++v) {
          group.clear();
          // v is vertex 0 of each contact of its group: a movable v settles `moves` without
          // reading the 96-byte records, which weigh_group reads only for groups of two or more.
          bool moves = movable.empty() || (static_cast<size_t>(v) < movable.size() && movable[v] > 0.0);
          for (Index q = row_start[v]; q < row_start[v + 1]; ++q)
            if (slots[q] % 4 == 0) {
              const Index ci = slots[q] / 4;
              group.push_back(ci);
              in_group[static_cast<size_t>(ci)] = 1;
              for (int k = 0; !moves && k < contacts[ci].size(); ++k) moves = movable[contacts[ci].v[k]] > 0.0;
            }
          local += static_cast<Index>(group.size());
          if (moves) weigh_group(group, contacts, width, vis, scratch);
        }
        grouped += local;
      },
      256);
  if (grouped.load() == n) return;  // no contact left for the scan below
  // Contacts whose query vertex is not listed (not movable: every movable vertex lists its own
  // contacts) are grouped apart: collected per block in index order, then stably by vertex. A
  // grouped contact sits in its query vertex's non-empty row, so only the others are read.
  const Index blocks = std::clamp<Index>(n / 4096, 1, 32);
  std::vector<std::vector<Index>> found(static_cast<size_t>(blocks));
  parallel_chunks(n, blocks, [&](Index b, Index lo, Index hi) {
    for (Index i = lo; i < hi; ++i) {
      if (in_group[static_cast<size_t>(i)]) continue;
      const Index v = contacts[i].v[0];
      if (v >= nv || row_start[v + 1] == row_start[v]) found[b].push_back(i);
    }
  });
  std::vector<Index>& rest = ws.order;
  rest.clear();
  for (const auto& f : found) rest.insert(rest.end(), f.begin(), f.end());
  std::stable_sort(rest.begin(), rest.end(), [&](Index a, Index b) { return contacts[a].v[0] < contacts[b].v[0]; });
  GroupScratch scratch;
  for (size_t b = 0; b < rest.size();) {
    size_t e = b + 1;
    while (e < rest.size() && contacts[rest[e]].v[0] == contacts[rest[b]].v[0]) ++e;
    weigh_group(std::span<const Index>(rest).subspan(b, e - b), contacts, width, vis, scratch);
    b = e;
  }
}

}  // namespace ccfr
