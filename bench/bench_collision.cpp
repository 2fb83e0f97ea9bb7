// Collision detection benchmarks: each broad phase (boxes + refit + self-query) and the narrow
// phase on a 16k-vertex crumpled cloth (1 m sheet, ξ = 0.01, r = 0.005, δ = 0.0005) and a
// 40k-vertex curly strand bundle. Results: docs/perf/collision.md.
//
//   build/bench/bench_collision --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
#include <benchmark/benchmark.h>
#include <spdlog/spdlog.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <numbers>
#include <string>

#include "../tests/collision/scenes.hpp"
#include "ccfr/collision/narrow_phase.hpp"
#include "ccfr/core/parallel.hpp"
#include "ccfr/geometry/generators.hpp"

namespace {

using namespace ccfr;

constexpr ContactModel kParams{0.005, 0.01, 0.0005};

struct Scene {
  Topology topo;
  Positions x;
  std::vector<double> inv_mass;
};

/// 1 m sheet, 127 x 127 cells (16 384 vertices), folded three times like an accordion (turn
/// radius 12 mm, layers 24 mm apart) and rippled along its normal by sines of amplitude 3 mm < 12 mm:
/// an offset surface of a curve of curvature <= 1/12 mm with smaller offsets, hence free of
/// self-intersections, with layers 18-30 mm apart so that they interact across the 20 mm range.
Scene crumpled_cloth() {
  // The tests' accordion generator (tests/collision/scenes.hpp), so the benchmark measures the
  // geometry the brute-force tests certify.
  const gen::TriMesh m = ccfr::test::accordion_cloth(1.0, 127, 3, 0.012, 0.003);
  TopologyBuilder b;
  b.add_object("cloth", ObjectKind::cloth, static_cast<Index>(m.v.size()), m.f);
  return {b.finish(), m.v, std::vector<double>(m.v.size(), 1.0)};
}

/// 400 helical strands of 100 vertices (40 000 vertices), roots 13 mm apart on a 20 x 20 grid,
/// 0.5 m long, coil radius 10 mm, 5 turns: neighbours run 13 mm apart, inside the 20 mm range.
Scene strand_bundle() {
  gen::PolylineSet s = gen::curly_strands(400, 100, 0.5, 19 * 0.013, 0.01, 5.0);
  TopologyBuilder b;
  b.add_object("hair", ObjectKind::strand, static_cast<Index>(s.v.size()), {}, {}, s.lines);
  return {b.finish(), s.v, std::vector<double>(s.v.size(), 1.0)};
}

const Scene& scene(int which) {
  static const Scene cloth = crumpled_cloth();
  static const Scene strands = strand_bundle();
  return which == 0 ? cloth : strands;
}

const char* scene_name(int which) { return which == 0 ? "cloth16k" : "strands40k"; }

/// One broad-phase pass as the detector runs it: boxes, refit, self-query.
void BM_Broad(benchmark::State& state, std::string name) {
  spdlog::set_level(spdlog::level::warn);
  const Scene& s = scene(static_cast<int>(state.range(0)));
  const CollisionPrimitives prims = build_collision_primitives(s.topo);
  const double inflation = box_inflation(kParams.radius, kParams.offset, kParams.repulsion_range);
  std::vector<AABB> boxes;
  compute_primitive_boxes(prims, s.topo, s.x, inflation, boxes);
  auto bp = make_broad_phase(name);
  bp->build(boxes);
  std::vector<IndexPair> pairs;
  for (auto _ : state) {
    compute_primitive_boxes(prims, s.topo, s.x, inflation, boxes);
    bp->update(boxes);
    bp->query_pairs(pairs);
    benchmark::DoNotOptimize(pairs.data());
  }
  state.SetLabel(scene_name(static_cast<int>(state.range(0))));
  state.counters["primitives"] = static_cast<double>(prims.size());
  state.counters["candidates"] = static_cast<double>(pairs.size());
}

/// FNV-1a over every field of the regions (offsets, planes) and the contacts in order: equal
/// hashes before and after an optimisation show that the output is bit-identical.
std::uint64_t output_hash(const RegionSet& regions, const std::vector<ContactPair>& contacts) {
  std::uint64_t h = 1469598103934665603ull;
  auto mix = [&h](const auto& value) {
    unsigned char bytes[sizeof value];
    std::memcpy(bytes, &value, sizeof value);
    for (unsigned char b : bytes) h = (h ^ b) * 1099511628211ull;
  };
  for (Index o : regions.offsets) mix(o);
  for (const HalfSpace& p : regions.planes) {
    for (int k = 0; k < 3; ++k) mix(p.n[k]);
    mix(p.d);
  }
  for (const ContactPair& c : contacts) {
    mix(static_cast<int>(c.kind));
    for (int k = 0; k < 4; ++k) {
      mix(c.v[k]);
      mix(c.w[k]);
    }
    for (int k = 0; k < 3; ++k) mix(c.n[k]);
    mix(c.distance);
  }
  return h;
}

/// The narrow phase alone (manual time = DetectionStats::narrow_s), and the whole pass.
void BM_Detect(benchmark::State& state, bool narrow_only) {
  spdlog::set_level(spdlog::level::warn);
  const int which = static_cast<int>(state.range(0));
  const int threads = static_cast<int>(state.range(1));
  set_thread_count(threads);
  const Scene& s = scene(which);
  CollisionDetector det(s.topo, s.x, kParams, make_broad_phase(default_broad_phase_name()));
  RegionSet regions;
  std::vector<ContactPair> contacts;
  DetectionStats stats;
  det.detect(s.x, s.inv_mass, regions, contacts, stats);  // warm the reused buffers
  const std::uint64_t hash = output_hash(regions, contacts);
  for (auto _ : state) {
    det.detect(s.x, s.inv_mass, regions, contacts, stats);
    if (narrow_only) state.SetIterationTime(stats.narrow_s);
  }
  set_thread_count(0);
  char hex[17];
  std::snprintf(hex, sizeof hex, "%016llx", static_cast<unsigned long long>(hash));
  state.SetLabel(std::string(scene_name(which)) + ", " + std::to_string(threads) + " threads, output " + hex);
  state.counters["candidates"] = stats.candidates;
  state.counters["within_range"] = stats.pairs_within_range;
  state.counters["constraints"] = stats.constraints;
  state.counters["excluded"] = stats.excluded_initial;
  state.counters["broad_ms"] = 1e3 * stats.broad_s;
  state.counters["narrow_ms"] = 1e3 * stats.narrow_s;
}

BENCHMARK_CAPTURE(BM_Broad, bvh, std::string("bvh"))->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK_CAPTURE(BM_Broad, fcl, std::string("fcl"))->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK_CAPTURE(BM_Detect, narrow, true)
    ->Args({0, 2})
    ->Args({1, 2})
    ->Args({0, 1})
    ->Unit(benchmark::kMillisecond)
    ->UseManualTime();
BENCHMARK_CAPTURE(BM_Detect, full, false)
    ->Args({0, 2})
    ->Args({1, 2})
    ->Args({0, 1})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
