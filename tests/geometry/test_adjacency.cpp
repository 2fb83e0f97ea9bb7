#include <gtest/gtest.h>

#include <limits>

#include "ccfr/core/topology.hpp"
#include "ccfr/geometry/adjacency.hpp"
#include "ccfr/geometry/generators.hpp"

using namespace ccfr;

namespace {
// All-pairs shortest edge paths by Floyd-Warshall: the independent answer for small meshes.
std::vector<std::vector<double>> floyd(const Topology& t, const Positions& x) {
  const Index n = t.num_vertices();
  const double inf = std::numeric_limits<double>::infinity();
  std::vector<std::vector<double>> d(static_cast<size_t>(n), std::vector<double>(static_cast<size_t>(n), inf));
  for (Index i = 0; i < n; ++i) d[i][i] = 0.0;
  for (const auto& e : t.edges) d[e[0]][e[1]] = d[e[1]][e[0]] = (x[e[0]] - x[e[1]]).norm();
  for (Index k = 0; k < n; ++k)
    for (Index i = 0; i < n; ++i)
      for (Index j = 0; j < n; ++j) d[i][j] = std::min(d[i][j], d[i][k] + d[k][j]);
  return d;
}
}  // namespace

TEST(TopologicalAdjacency, MatchesAllPairsShortestPathsOnTwoObjects) {
  const auto g = gen::grid(1.0, 0.6, 7, 4);  // uneven edge lengths in x and z
  TopologyBuilder b;
  b.add_object("a", ObjectKind::cloth, static_cast<Index>(g.v.size()), g.f);
  b.add_object("b", ObjectKind::cloth, static_cast<Index>(g.v.size()), g.f);
  const Topology t = b.finish();
  Positions x = g.v;
  for (const auto& p : g.v) x.push_back(p + Vec3(0, 0.001, 0));  // second sheet almost on the first
  const auto d = floyd(t, x);
  for (double radius : {0.0, 0.1, 0.25, 0.4}) {
    const TopologicalAdjacency adj(t, x, radius);
    for (Index i = 0; i < t.num_vertices(); ++i)
      for (Index j = 0; j < t.num_vertices(); ++j)
        EXPECT_EQ(adj.vertices_adjacent(i, j), d[i][j] <= radius) << i << " " << j << " radius " << radius;
  }
}

TEST(TopologicalAdjacency, ObjectsNeverConnectAndSetsUseAnyVertex) {
  const auto g = gen::grid(1.0, 1.0, 2, 2);
  TopologyBuilder b;
  b.add_object("a", ObjectKind::cloth, static_cast<Index>(g.v.size()), g.f);
  b.add_object("b", ObjectKind::cloth, static_cast<Index>(g.v.size()), g.f);
  const Topology t = b.finish();
  Positions x = g.v;
  x.insert(x.end(), g.v.begin(), g.v.end());  // coincident copies: distance 0, but no path
  const TopologicalAdjacency adj(t, x, 10.0);
  const Index n = static_cast<Index>(g.v.size());
  EXPECT_FALSE(adj.vertices_adjacent(0, n));
  const Index a[] = {0, 1}, c[] = {n, n + 1}, e[] = {n + 2, 1};
  EXPECT_FALSE(adj.adjacent(a, c));
  EXPECT_TRUE(adj.adjacent(a, e));
  EXPECT_THROW(TopologicalAdjacency(t, g.v, 1.0), std::exception);  // wrong size
}
