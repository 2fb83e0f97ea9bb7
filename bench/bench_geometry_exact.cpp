// Penetration audit time per frame: a 16k-vertex crumpled cloth and a 40k-vertex strand bundle;
// and the cost of the exact primitives.
#include <benchmark/benchmark.h>

#include <cmath>
#include <random>
#include <vector>

#include "ccfr/core/parallel.hpp"
#include "ccfr/geometry_exact/audit.hpp"
#include "ccfr/geometry_exact/predicates.hpp"

namespace {

using namespace ccfr;

struct SceneData {
  Topology topo;
  Positions x;
};

// 128 x 128 cells on a 1 m square (16641 vertices), displaced by a sum of sines (a height field,
// so it is crumpled but free of self-intersections).
SceneData crumpled_cloth() {
  const int n = 128;
  SceneData s;
  std::vector<Vec3i> faces;
  for (int i = 0; i <= n; ++i)
    for (int j = 0; j <= n; ++j) {
      const double x = double(i) / n, z = double(j) / n;
      const double y =
          0.05 * std::sin(9 * x) * std::cos(7 * z) + 0.02 * std::sin(23 * x + 17 * z) + 0.01 * std::cos(41 * z - 3 * x);
      s.x.emplace_back(x, y, z);
    }
  auto id = [&](int i, int j) { return static_cast<Index>(i * (n + 1) + j); };
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      faces.emplace_back(id(i, j), id(i + 1, j), id(i + 1, j + 1));
      faces.emplace_back(id(i, j), id(i + 1, j + 1), id(i, j + 1));
    }
  TopologyBuilder b;
  b.add_object("cloth", ObjectKind::cloth, (n + 1) * (n + 1), faces);
  s.topo = b.finish();
  return s;
}

// 400 curly strands of 100 vertices (40k vertices), 0.3 m long, roots 4 mm apart on a 20 x 20 grid.
SceneData strand_bundle() {
  SceneData s;
  std::vector<std::vector<Index>> lines;
  const int count = 400, verts = 100;
  for (int k = 0; k < count; ++k) {
    std::vector<Index> line;
    const double rx = 0.004 * (k % 20), rz = 0.004 * (k / 20), phase = 0.37 * k;
    for (int v = 0; v < verts; ++v) {
      const double t = double(v) / (verts - 1);
      const double a = 2 * M_PI * 6 * t + phase;
      line.push_back(static_cast<Index>(s.x.size()));
      s.x.emplace_back(rx + 0.0015 * std::cos(a), -0.3 * t, rz + 0.0015 * std::sin(a));
    }
    lines.push_back(line);
  }
  TopologyBuilder b;
  b.add_object("hair", ObjectKind::strand, count * verts, {}, {}, lines);
  s.topo = b.finish();
  return s;
}

Positions perturbed(const Positions& x, double amp) {
  std::mt19937_64 g(7);
  std::uniform_real_distribution<double> u(-amp, amp);
  Positions y = x;
  for (auto& p : y) p += Vec3(u(g), u(g), u(g));
  return y;
}

void run_audit(benchmark::State& state, const SceneData& s, double xi) {
  set_thread_count(static_cast<int>(state.range(0)));
  exact::AuditOptions opt;
  opt.offset = xi;
  const exact::PenetrationAudit audit(s.topo, s.x, opt);
  const Positions y = perturbed(s.x, 0.1 * xi);
  exact::FrameAudit r;
  for (auto _ : state) r = audit.audit(y);
  state.counters["checked"] = static_cast<double>(r.checked_pairs);
  state.counters["violations"] = static_cast<double>(r.penetrations());
  state.counters["excluded"] = static_cast<double>(audit.excluded_close_pairs());
  set_thread_count(0);
}

void BM_AuditCrumpledCloth16k(benchmark::State& state) {
  static const SceneData s = crumpled_cloth();
  run_audit(state, s, 0.001);
}
BENCHMARK(BM_AuditCrumpledCloth16k)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_AuditStrandBundle40k(benchmark::State& state) {
  static const SceneData s = strand_bundle();
  run_audit(state, s, 0.001);
}
BENCHMARK(BM_AuditStrandBundle40k)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();

std::vector<Vec3> random_points(int n, std::uint64_t seed) {
  std::mt19937_64 g(seed);
  std::uniform_real_distribution<double> u(-1, 1);
  std::vector<Vec3> p(n);
  for (auto& v : p) v = Vec3(u(g), u(g), u(g));
  return p;
}

void BM_TriangleTriangleExact(benchmark::State& state) {
  const auto p = random_points(6 * 1024, 1);
  size_t i = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(exact::triangles_intersect(p[i], p[i + 1], p[i + 2], p[i + 3], p[i + 4], p[i + 5]));
    i = (i + 6) % (6 * 1024);
  }
}
BENCHMARK(BM_TriangleTriangleExact);

// Thresholds at the distance itself: every call misses the double filter and runs the exact kernel.
void BM_PointTriangleCompareExactPath(benchmark::State& state) {
  const auto p = random_points(4 * 256, 2);
  std::vector<double> d(256);
  for (int k = 0; k < 256; ++k)
    d[k] = exact::exact_point_triangle_distance_sq(p[4 * k], p[4 * k + 1], p[4 * k + 2], p[4 * k + 3]);
  size_t k = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(
        exact::compare_point_triangle_distance_sq(p[4 * k], p[4 * k + 1], p[4 * k + 2], p[4 * k + 3], d[k]));
    k = (k + 1) & 255;
  }
}
BENCHMARK(BM_PointTriangleCompareExactPath);

void BM_EdgeEdgeCompareExactPath(benchmark::State& state) {
  const auto p = random_points(4 * 256, 3);
  std::vector<double> d(256);
  for (int k = 0; k < 256; ++k)
    d[k] = exact::exact_edge_edge_distance_sq(p[4 * k], p[4 * k + 1], p[4 * k + 2], p[4 * k + 3]);
  size_t k = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(
        exact::compare_edge_edge_distance_sq(p[4 * k], p[4 * k + 1], p[4 * k + 2], p[4 * k + 3], d[k]));
    k = (k + 1) & 255;
  }
}
BENCHMARK(BM_EdgeEdgeCompareExactPath);

// Thresholds far from the distance: the double filter decides.
void BM_PointTriangleCompareFiltered(benchmark::State& state) {
  const auto p = random_points(4 * 256, 2);
  size_t k = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(
        exact::compare_point_triangle_distance_sq(p[4 * k], p[4 * k + 1], p[4 * k + 2], p[4 * k + 3], 1e-6));
    k = (k + 1) & 255;
  }
}
BENCHMARK(BM_PointTriangleCompareFiltered);

}  // namespace

BENCHMARK_MAIN();
