// Collision detection benchmarks: each broad phase (boxes + refit + self-query) and the narrow
// phase on a 16k-vertex crumpled cloth (1 m sheet, ξ = 0.01, r = 0.005, δ = 0.0005) and a
// 40k-vertex curly strand bundle. Results: docs/perf/collision.md.
//
//   build/bench/bench_collision --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
#include <benchmark/benchmark.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <numbers>
#include <string>

#include "../tests/collision/scenes.hpp"
#include "ccfr/collision/collision_detector.hpp"
#include "ccfr/core/parallel.hpp"
#include "ccfr/feasibility/projector.hpp"
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

/// FNV-1a over every field of the regions (row starts, planes) and the contacts in order: equal
/// hashes before and after an optimisation show that the output is bit-identical.
std::uint64_t output_hash(const RegionSet& regions, const std::vector<ContactPair>& contacts) {
  std::uint64_t h = 1469598103934665603ull;
  auto mix = [&h](const auto& value) {
    unsigned char bytes[sizeof value];
    std::memcpy(bytes, &value, sizeof value);
    for (unsigned char b : bytes) h = (h ^ b) * 1099511628211ull;
  };
  for (Index o : regions.row_start) mix(o);
  for (const HalfSpace& p : regions.rows()) {
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

/// Bytes a pass writes into the RegionSet: row starts, per-contact records and per-slot references.
size_t region_bytes(const RegionSet& r) {
  return r.row_start.size() * sizeof(Index) + r.records.size() * sizeof(RegionRecord) +
         r.refs.size() * sizeof(std::uint32_t);
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
  state.counters["regions_MB"] = 1e-6 * static_cast<double>(region_bytes(regions));
}

/// The region screen ("is the candidate outside any plane of its vertex?", projector.cpp) in two
/// layouts, on the 16k cloth's regions with every vertex displaced by arg1 % of r in a fixed
/// pseudo-random direction (issue 38 item 1): arg 0 reads each vertex's CSR row of references
/// into the per-contact records (the production layout since the compact region); arg 1 streams one record per contact
/// {n, d_A, d_B} in contact order and marks the vertices it finds outside, the screen a compact region would run. Both
/// must mark the same vertices (checked before timing).
void BM_Screen(benchmark::State& state) {
  spdlog::set_level(spdlog::level::warn);
  const int layout = static_cast<int>(state.range(0));
  const Scene& s = scene(0);
  CollisionDetector det(s.topo, s.x, kParams, make_broad_phase(default_broad_phase_name()));
  RegionSet regions;
  std::vector<ContactPair> contacts;
  DetectionStats stats;
  det.detect(s.x, s.inv_mass, regions, contacts, stats);
  // The compact record of each contact, recovered from the CSR: a vertex's planes are in contact
  // order, so a per-vertex cursor pairs each contact with its plane (every vertex is movable here).
  struct Compact {
    Vec3 n;
    double d[2];
  };
  // Self-contained: the vertices too (64 bytes), so the screen reads one array.
  struct Packed {
    std::int32_t v[4];
    std::int32_t size_na;
    Vec3 n;
    double d[2];
  };
  std::vector<Compact> compact(contacts.size());
  std::vector<Index> seen(static_cast<size_t>(regions.num_vertices()), 0);
  for (size_t i = 0; i < contacts.size(); ++i) {
    const ContactPair& c = contacts[i];
    compact[i].n = c.n;
    for (int k = 0; k < c.size(); ++k) {
      const HalfSpace h = regions.plane(regions.row_start[c.v[k]] + seen[c.v[k]]++);
      compact[i].d[k < c.side_a() ? 0 : 1] = h.d;
    }
  }
  std::vector<Packed> packed(contacts.size());
  for (size_t i = 0; i < contacts.size(); ++i) {
    const ContactPair& c = contacts[i];
    for (int k = 0; k < 4; ++k) packed[i].v[k] = k < c.size() ? c.v[k] : 0;
    packed[i].size_na = c.size() * 4 + c.side_a();
    packed[i].n = c.n;
    packed[i].d[0] = compact[i].d[0];
    packed[i].d[1] = compact[i].d[1];
  }
  Positions x = s.x;
  std::uint64_t rng = 88172645463325252ull;
  auto uniform = [&rng] {
    rng ^= rng << 13, rng ^= rng >> 7, rng ^= rng << 17;
    return static_cast<double>(rng >> 11) * 0x1.0p-53;
  };
  for (Vec3& p : x) {
    const double z = 2.0 * uniform() - 1.0, phi = 2.0 * std::numbers::pi * uniform();
    const double rho = std::sqrt(1.0 - z * z);
    p +=
        0.01 * static_cast<double>(state.range(1)) * kParams.radius * Vec3(rho * std::cos(phi), rho * std::sin(phi), z);
  }
  const Index nv = regions.num_vertices();
  std::vector<unsigned char> outside(static_cast<size_t>(nv));
  auto csr_screen = [&] {
    for (Index v = 0; v < nv; ++v)
      outside[static_cast<size_t>(v)] = regions.count(v) > 0 && regions.falls_below(v, s.x[v], x[v], 0.0);
  };
  auto compact_screen = [&] {
    std::fill(outside.begin(), outside.end(), 0);
    for (size_t i = 0; i < contacts.size(); ++i) {
      const ContactPair& c = contacts[i];
      const Compact& r = compact[i];
      const int na = c.side_a();
      for (int k = 0; k < c.size(); ++k) {
        const Index v = c.v[k];
        const double along = (x[v] - s.x[v]).dot(r.n);
        const bool out = k < na ? along + r.d[0] < 0.0 : -along + r.d[1] < 0.0;
        outside[static_cast<size_t>(v)] |= static_cast<unsigned char>(out);
      }
    }
  };
  auto packed_screen = [&] {
    std::fill(outside.begin(), outside.end(), 0);
    for (const Packed& r : packed) {
      const int size = r.size_na >> 2, na = r.size_na & 3;
      for (int k = 0; k < size; ++k) {
        const Index v = r.v[k];
        const double along = (x[v] - s.x[v]).dot(r.n);
        const bool out = k < na ? along + r.d[0] < 0.0 : -along + r.d[1] < 0.0;
        outside[static_cast<size_t>(v)] |= static_cast<unsigned char>(out);
      }
    }
  };
  // What the compact layout saves: writing the per-vertex rows (count, prefix sum, fill), serially.
  struct {
    std::vector<Index> row_start;
    std::vector<HalfSpace> planes;
  } rows;
  auto build_rows = [&] {
    rows.row_start.assign(static_cast<size_t>(nv) + 1, 0);
    for (const Packed& r : packed)
      for (int k = 0; k < (r.size_na >> 2); ++k) ++rows.row_start[static_cast<size_t>(r.v[k]) + 1];
    for (Index v = 0; v < nv; ++v) rows.row_start[v + 1] += rows.row_start[v];
    seen.assign(rows.row_start.begin(), rows.row_start.end() - 1);
    rows.planes.resize(static_cast<size_t>(rows.row_start.back()));
    for (const Packed& r : packed) {
      const int size = r.size_na >> 2, na = r.size_na & 3;
      for (int k = 0; k < size; ++k) {
        HalfSpace& h = rows.planes[static_cast<size_t>(seen[r.v[k]]++)];
        h.n = k < na ? r.n : Vec3(-r.n);
        h.d = r.d[k < na ? 0 : 1];
      }
    }
  };
  csr_screen();
  const std::vector<unsigned char> reference = outside;
  compact_screen();
  const bool same1 = outside == reference;
  packed_screen();
  build_rows();
  if (rows.row_start != regions.row_start ||
      std::memcmp(rows.planes.data(), regions.rows().data(), rows.planes.size() * sizeof(HalfSpace)) != 0) {
    state.SkipWithError("the rebuilt rows differ");
    return;
  }
  if (!same1 || outside != reference) {
    state.SkipWithError("the two screens disagree");
    return;
  }
  for (auto _ : state) {
    if (layout == 0)
      csr_screen();
    else if (layout == 1)
      compact_screen();
    else if (layout == 2)
      packed_screen();
    else {
      if (layout == 3) rows.planes = {};  // a fresh allocation: the page faults of a pass that outgrew the last
      build_rows();                       // layout 4: into the last pass's capacity, as the detector does
    }
    benchmark::DoNotOptimize(outside.data());
  }
  state.SetLabel(layout == 0   ? "per-vertex CSR rows of references into per-contact records"
                 : layout == 1 ? "contacts + {n, d_A, d_B} per contact, contact order"
                 : layout == 2 ? "64-byte record per contact, contact order"
                 : layout == 3 ? "writing the CSR rows from the records (count, fill), fresh memory"
                               : "writing the CSR rows from the records (count, fill), reused memory");
  state.counters["outside"] = static_cast<double>(std::count(reference.begin(), reference.end(), 1));
  state.counters["planes"] = static_cast<double>(regions.total());
  state.counters["contacts"] = static_cast<double>(contacts.size());
  state.counters["bytes_MB"] = 1e-6 * static_cast<double>(layout > 2    ? regions.total() * sizeof(HalfSpace)
                                                          : layout == 0 ? region_bytes(regions)
                                                          : layout == 1 ? compact.size() * sizeof(Compact)
                                                                        : packed.size() * sizeof(Packed));
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
BENCHMARK(BM_Screen)->ArgsProduct({{0, 1, 2, 3, 4}, {0, 5, 50}})->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
