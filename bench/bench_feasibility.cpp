// Projector throughput (projections per second for 1-16 half-spaces), project_all on 16k vertices,
// and, with --report, the measurements behind the defaults: Plesník's halting rate per outer-pass
// budget and its distance to the exact projection. See docs/perf/feasibility.md.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <random>
#include <string>
#include <vector>

#include "../tests/feasibility/random_regions.hpp"
#include "ccfr/core/parallel.hpp"
#include "ccfr/feasibility/projector.hpp"

namespace {

using namespace ccfr;

/// `n` problems with exactly `planes` half-spaces whose candidate violates at least one of them.
std::vector<test::RandomProblem> violated_problems(int planes, int n, std::uint64_t seed) {
  auto g = std::mt19937_64(seed);
  std::vector<test::RandomProblem> out;
  while (static_cast<int>(out.size()) < n) {
    auto p = test::random_problem(g, planes);
    if (min_value(p.anchor, p.candidate, p.planes) < 0.0) out.push_back(std::move(p));
  }
  return out;
}

void BM_Project(benchmark::State& state, const char* name) {
  const auto proj = make_projector(name);
  const auto probs = violated_problems(static_cast<int>(state.range(0)), 4096, 42);
  size_t i = 0;
  for (auto _ : state) {
    const auto& p = probs[i];
    benchmark::DoNotOptimize(proj->project(p.anchor, p.candidate, p.planes));
    i = (i + 1) % probs.size();
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK_CAPTURE(BM_Project, plesnik, "plesnik")->Arg(1)->Arg(2)->Arg(4)->Arg(8)->Arg(16);
BENCHMARK_CAPTURE(BM_Project, successive_projection, "successive_projection")->Arg(1)->Arg(2)->Arg(4)->Arg(8)->Arg(16);
BENCHMARK_CAPTURE(BM_Project, exact, "exact")->Arg(1)->Arg(2)->Arg(4)->Arg(8)->Arg(16);

/// Empty regions (the anchor outside, clarification 7): `planes` half-spaces around the anchor
/// plus two opposing ones 1 mm apart in the wrong order (x >= 0.001 and x <= 0), so no point is
/// feasible. The exact projector must say `infeasible`; before the Farkas test it ran 20,000
/// Hildreth sweeps per call for <= 24 planes.
void BM_RejectEmptyRegion(benchmark::State& state) {
  const auto proj = make_projector("exact");
  auto g = std::mt19937_64(7);
  std::vector<test::RandomProblem> probs;
  for (int k = 0; k < 64; ++k) {
    auto p = test::random_problem(g, static_cast<int>(state.range(0)) - 2);
    p.planes.push_back({Vec3::UnitX(), -0.001});
    p.planes.push_back({-Vec3::UnitX(), 0.0});
    probs.push_back(std::move(p));
  }
  size_t i = 0;
  for (auto _ : state) {
    const auto& p = probs[i];
    benchmark::DoNotOptimize(proj->project(p.anchor, p.candidate, p.planes));
    i = (i + 1) % probs.size();
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_RejectEmptyRegion)->Arg(4)->Arg(16)->Arg(24)->Unit(benchmark::kMicrosecond);

/// A 16k-vertex batch shaped like a contact-rich cloth frame: 40 % of the vertices without
/// half-spaces, the others with 1-12 (mean about 3), normals clustered half of the time, and the
/// candidate within 1.5 r of the anchor so that about half of the constrained vertices violate.
struct Batch {
  RegionSet regions;
  Positions anchor, candidate;
  std::vector<double> inv_mass;
};

const Batch& batch_16k() {
  static const Batch b = [] {
    Batch out;
    const Index n = 16384;
    auto g = std::mt19937_64(7);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    std::geometric_distribution<int> extra(0.33);
    std::vector<std::vector<TaggedHalfSpace>> buf(1);
    out.anchor.resize(n);
    out.candidate.resize(n);
    out.inv_mass.assign(n, 1.0);
    for (Index v = 0; v < n; ++v) {
      const int count = u(g) < 0.4 ? 0 : std::min(12, 1 + extra(g));
      const auto p = test::random_problem(g, count);
      out.anchor[static_cast<size_t>(v)] = p.anchor;
      out.candidate[static_cast<size_t>(v)] = p.candidate;
      for (size_t k = 0; k < p.planes.size(); ++k) buf[0].push_back({v, static_cast<std::uint64_t>(k), p.planes[k]});
    }
    build_region_set(n, buf, out.regions);
    return out;
  }();
  return b;
}

void BM_ProjectAll(benchmark::State& state, const char* name) {
  const auto proj = make_projector(name);
  const Batch& b = batch_16k();
  Positions x;
  BatchStats s;
  for (auto _ : state) {
    state.PauseTiming();
    x = b.candidate;
    state.ResumeTiming();
    s = project_all(*proj, b.regions, b.anchor, x, b.inv_mass);
    benchmark::DoNotOptimize(x.data());
  }
  state.SetItemsProcessed(state.iterations() * b.regions.num_vertices());
  state.counters["violated"] = static_cast<double>(s.violated);
  state.counters["halted"] = static_cast<double>(s.halted);
  state.counters["infeasible"] = static_cast<double>(s.infeasible);
  state.counters["remaining"] = static_cast<double>(s.remaining);
}
BENCHMARK_CAPTURE(BM_ProjectAll, plesnik, "plesnik")->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK_CAPTURE(BM_ProjectAll, successive_projection, "successive_projection")
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK_CAPTURE(BM_ProjectAll, exact, "exact")->Unit(benchmark::kMillisecond)->UseRealTime();

double percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  return v[static_cast<size_t>(
      std::min<double>(static_cast<double>(v.size() - 1), std::floor(q * static_cast<double>(v.size()))))];
}

/// Halting rate per pass budget and the distance to the exact projection, on violated problems
/// with 1-16 half-spaces (equal shares per count).
void report() {
  std::vector<test::RandomProblem> probs;
  for (int k = 1; k <= 16; ++k) {
    auto v = violated_problems(k, 4000, 1000 + static_cast<std::uint64_t>(k));
    probs.insert(probs.end(), v.begin(), v.end());
  }
  const auto exact = make_projector("exact");
  std::vector<Vec3> ex(probs.size());
  for (size_t i = 0; i < probs.size(); ++i)
    ex[i] = exact->project(probs[i].anchor, probs[i].candidate, probs[i].planes).x;

  std::printf("# Plesnik halting rate per max_iterations (%zu violated problems, 1-16 planes)\n", probs.size());
  std::printf("max_iterations,halted,halted_pct,mean_passes\n");
  for (int budget : {1, 2, 3, 4, 6, 8, 16, 64}) {
    ProjectorParams p;
    p.max_iterations = budget;
    p.exact_fallback = false;  // Plesník's own passes: the rescue would hide every halt
    const auto pl = make_projector("plesnik", p);
    size_t halted = 0;
    double passes = 0;
    for (const auto& pr : probs) {
      const auto r = pl->project(pr.anchor, pr.candidate, pr.planes);
      halted += r.status == ProjectStatus::halted;
      passes += r.iterations;
    }
    std::printf("%d,%zu,%.3f,%.3f\n", budget, halted,
                100.0 * static_cast<double>(halted) / static_cast<double>(probs.size()),
                passes / static_cast<double>(probs.size()));
  }

  ProjectorParams plain;
  plain.exact_fallback = false;  // the halted share below is Plesník's own
  const auto pl = make_projector("plesnik", plain);
  const auto sp = make_projector("successive_projection");
  std::printf("\n# distance to the exact projection (default parameters, non-halted Plesnik results)\n");
  std::printf(
      "planes,count,halted_pct,p50,p90,p99,max,rel_p50,rel_p90,rel_p99,rel_max,farther_than_anchor_pct,succ_infeasible_"
      "pct\n");
  auto row = [&](int lo, int hi) {
    std::vector<double> gap, rel;
    size_t n = 0, halted = 0, sp_bad = 0, far = 0;
    for (size_t i = 0; i < probs.size(); ++i) {
      const auto& pr = probs[i];
      const int k = static_cast<int>(pr.planes.size());
      if (k < lo || k > hi) continue;
      ++n;
      const auto r = pl->project(pr.anchor, pr.candidate, pr.planes);
      sp_bad += sp->project(pr.anchor, pr.candidate, pr.planes).status == ProjectStatus::infeasible;
      if (r.status == ProjectStatus::halted) {
        ++halted;
        continue;
      }
      // The anchor is feasible, so a result farther from the candidate than the anchor is a poor one.
      far += (r.x - pr.candidate).norm() > (pr.anchor - pr.candidate).norm();
      gap.push_back((r.x - ex[i]).norm());
      rel.push_back(gap.back() / std::max(1e-300, (ex[i] - pr.candidate).norm()));
    }
    std::printf("%d-%d,%zu,%.3f,%.2e,%.2e,%.2e,%.2e,%.2e,%.2e,%.2e,%.2e,%.2f,%.2f\n", lo, hi, n,
                100.0 * static_cast<double>(halted) / static_cast<double>(n), percentile(gap, 0.5),
                percentile(gap, 0.9), percentile(gap, 0.99), percentile(gap, 1.0), percentile(rel, 0.5),
                percentile(rel, 0.9), percentile(rel, 0.99), percentile(rel, 1.0),
                100.0 * static_cast<double>(far) / static_cast<double>(n),
                100.0 * static_cast<double>(sp_bad) / static_cast<double>(n));
  };
  for (int k : {1, 2, 4, 8, 16}) row(k, k);
  row(1, 16);

  const Batch& b = batch_16k();
  Index constrained = 0;
  for (Index v = 0; v < b.regions.num_vertices(); ++v) constrained += b.regions.count(v) > 0;
  std::printf("\n# project_all batch: %d vertices, %d with half-spaces, %zu half-spaces, threads %d\n",
              b.regions.num_vertices(), constrained, b.regions.total(), thread_count());
  for (const auto& name : projector_names()) {
    Positions x = b.candidate;
    const auto s = project_all(*make_projector(name), b.regions, b.anchor, x, b.inv_mass);
    std::printf("%s: violated %d projected %d halted %d infeasible %d remaining %d iterations %lld\n", name.c_str(),
                s.violated, s.projected, s.halted, s.infeasible, s.remaining, static_cast<long long>(s.iterations));
  }
}

}  // namespace

int main(int argc, char** argv) {
  for (int i = 1; i < argc; ++i)
    if (std::strcmp(argv[i], "--report") == 0) {
      report();
      return 0;
    }
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
