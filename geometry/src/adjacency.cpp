#include "ccfr/geometry/adjacency.hpp"

#include <algorithm>
#include <queue>
#include <utility>

#include "ccfr/core/error.hpp"

namespace ccfr {

TopologicalAdjacency::TopologicalAdjacency(const Topology& topo, const Positions& rest, double radius)
    : TopologicalAdjacency(topo, rest, radius, {}) {}

TopologicalAdjacency::TopologicalAdjacency(const Topology& topo, const Positions& rest, double radius,
                                           std::span<const std::uint8_t> sources)
    : radius_(radius) {
  const Index nv = topo.num_vertices();
  if (!sources.empty() && static_cast<Index>(sources.size()) != nv)
    throw Error("TopologicalAdjacency: " + std::to_string(sources.size()) + " source flags for " + std::to_string(nv) +
                " vertices");
  if (static_cast<Index>(rest.size()) != nv)
    throw Error("TopologicalAdjacency: " + std::to_string(rest.size()) + " positions for " + std::to_string(nv) +
                " vertices");
  if (!(radius >= 0.0)) throw Error("TopologicalAdjacency: radius must be >= 0");
  near_.row_start.assign(static_cast<size_t>(nv) + 1, 0);
  near_.indices.clear();
  if (radius == 0.0) return;
  // Bounded Dijkstra from every vertex over its incident edges. `dist` is reset only where it was
  // touched, so the cost is the sum of the neighbourhood sizes, not #V squared.
  std::vector<double> dist(static_cast<size_t>(nv), -1.0);
  std::vector<Index> touched, found;
  using Item = std::pair<double, Index>;
  std::priority_queue<Item, std::vector<Item>, std::greater<>> heap;
  for (Index s = 0; s < nv; ++s) {
    if (!sources.empty() && !sources[s]) {
      near_.row_start[s + 1] = static_cast<Index>(near_.indices.size());
      continue;
    }
    dist[s] = 0.0;
    touched.push_back(s);
    heap.emplace(0.0, s);
    while (!heap.empty()) {
      const auto [d, v] = heap.top();
      heap.pop();
      if (d > dist[v]) continue;
      if (v != s) found.push_back(v);
      for (Index e : topo.vertex_edges.row(v)) {
        const Index w = topo.edges[e][0] == v ? topo.edges[e][1] : topo.edges[e][0];
        const double nd = d + (rest[w] - rest[v]).norm();
        if (nd > radius) continue;
        if (dist[w] < 0.0)
          touched.push_back(w);
        else if (nd >= dist[w])
          continue;
        dist[w] = nd;
        heap.emplace(nd, w);
      }
    }
    std::sort(found.begin(), found.end());
    near_.indices.insert(near_.indices.end(), found.begin(), found.end());
    near_.row_start[s + 1] = static_cast<Index>(near_.indices.size());
    for (Index t : touched) dist[t] = -1.0;
    touched.clear();
    found.clear();
  }
}

bool TopologicalAdjacency::vertices_adjacent(Index a, Index b) const {
  if (a == b) return true;
  if (near_.row_start.size() <= 1) return false;
  const auto ra = near_.row(a), rb = near_.row(b);
  return std::binary_search(ra.begin(), ra.end(), b) || std::binary_search(rb.begin(), rb.end(), a);
}

bool TopologicalAdjacency::adjacent(std::span<const Index> a, std::span<const Index> b) const {
  for (Index u : a)
    for (Index v : b)
      if (vertices_adjacent(u, v)) return true;
  return false;
}

}  // namespace ccfr
