// Geometry kernels: closest-point throughput and BVH refit + self-query on a 16k-vertex cloth.
#include <benchmark/benchmark.h>

#include <cmath>
#include <random>
#include <vector>

#include "ccfr/core/parallel.hpp"
#include "ccfr/geometry/bvh.hpp"
#include "ccfr/geometry/distance.hpp"

namespace {

using namespace ccfr;

std::vector<Vec3> random_points(int n, std::uint64_t seed) {
  std::mt19937_64 g(seed);
  std::uniform_real_distribution<double> u(-1, 1);
  std::vector<Vec3> p(n);
  for (auto& v : p) v = Vec3(u(g), u(g), u(g));
  return p;
}

void BM_PointTriangle(benchmark::State& state) {
  const auto p = random_points(4096, 1);
  size_t i = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(point_triangle(p[i], p[i + 1], p[i + 2], p[i + 3]).distance_sq);
    i = (i + 4) & 4095;
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_PointTriangle);

void BM_EdgeEdge(benchmark::State& state) {
  const auto p = random_points(4096, 2);
  size_t i = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(edge_edge(p[i], p[i + 1], p[i + 2], p[i + 3]).distance_sq);
    i = (i + 4) & 4095;
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_EdgeEdge);

void BM_PointEdge(benchmark::State& state) {
  const auto p = random_points(4096, 3);
  size_t i = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(point_edge(p[i], p[i + 1], p[i + 2]).distance_sq);
    i = (i + 3) % 4095;
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_PointEdge);

// 128 x 128 cells on a 1 m square (16641 vertices, 32768 triangles); crumple > 0 displaces the
// grid by a sum of sines of that amplitude (m), folding it onto itself in places.
std::vector<AABB> cloth_boxes(double crumple, double margin) {
  const int res = 128;
  auto at = [&](int i, int j) {
    const double x = double(i) / res, z = double(j) / res;
    const double y = crumple * (std::sin(9 * x) * std::cos(7 * z) + 0.5 * std::sin(23 * x + 17 * z) +
                                0.25 * std::cos(41 * z - 3 * x));
    return Vec3(x + 0.3 * crumple * std::sin(13 * z), y, z + 0.3 * crumple * std::cos(11 * x));
  };
  std::vector<AABB> boxes;
  for (int i = 0; i < res; ++i)
    for (int j = 0; j < res; ++j) {
      AABB a = AABB::of(at(i, j), at(i + 1, j), at(i + 1, j + 1));
      AABB b = AABB::of(at(i, j), at(i + 1, j + 1), at(i, j + 1));
      a.inflate(margin);
      b.inflate(margin);
      boxes.push_back(a);
      boxes.push_back(b);
    }
  return boxes;
}

void BM_BvhRefitSelfPairs(benchmark::State& state) {
  set_thread_count(static_cast<int>(state.range(0)));
  const auto boxes = cloth_boxes(state.range(1) / 1000.0, 0.01);
  Bvh bvh;
  bvh.build(boxes, 4);
  std::vector<std::pair<Index, Index>> pairs;
  for (auto _ : state) {
    bvh.refit(boxes);
    bvh.self_pairs(pairs);
    benchmark::DoNotOptimize(pairs.data());
  }
  state.counters["pairs"] = static_cast<double>(pairs.size());
  set_thread_count(0);
}
// Args: threads, crumple amplitude in mm (0: a flat 1 m cloth).
BENCHMARK(BM_BvhRefitSelfPairs)
    ->Args({1, 0})
    ->Args({2, 0})
    ->Args({1, 100})
    ->Args({2, 100})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

void BM_BvhBuild(benchmark::State& state) {
  const auto boxes = cloth_boxes(0.1, 0.01);
  Bvh bvh;
  for (auto _ : state) bvh.build(boxes, 4);
}
BENCHMARK(BM_BvhBuild)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
