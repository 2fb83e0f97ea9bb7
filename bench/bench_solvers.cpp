// The contact response's visibility weights (ContactResponse, paper Eq. 7's occlusion product) for
// groups of k contacts per query vertex whose gaps all lie within one width: the dense stacks'
// regime (a landed 50-layer stack's vertices hold dozens). Contacts in random order, as a detection
// pass leaves them; one thread. See docs/performance.md.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <random>
#include <vector>

#include "ccfr/core/parallel.hpp"
#include "ccfr/solvers/contact_response.hpp"

namespace {

using namespace ccfr;

/// `groups` query vertices with `k` contacts each, gaps uniform in [0, 0.9 width), shuffled.
std::vector<ContactPair> wide_windows(Index groups, int k, double width) {
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> gap(0.0, 0.9 * width);
  std::vector<ContactPair> cs;
  cs.reserve(static_cast<size_t>(groups) * static_cast<size_t>(k));
  for (Index g = 0; g < groups; ++g)
    for (int i = 0; i < k; ++i) {
      ContactPair c;
      c.v = {g, groups, groups + 1, groups + 2};
      c.offset = 0.004;
      c.distance = c.offset + gap(rng);
      cs.push_back(c);
    }
  std::shuffle(cs.begin(), cs.end(), rng);
  return cs;
}

void BM_VisibilityWeights(benchmark::State& state) {
  const int k = static_cast<int>(state.range(0));
  const double width = 0.001;
  const auto cs = wide_windows(static_cast<Index>(400'000 / k), k, width);
  set_thread_count(1);
  std::vector<double> vis;
  VisibilityWorkspace ws;
  for (auto _ : state) {
    visibility_weights(cs, width, vis, ws);
    benchmark::DoNotOptimize(vis.data());
  }
  set_thread_count(0);
  state.SetItemsProcessed(state.iterations() * static_cast<int64_t>(cs.size()));
}
BENCHMARK(BM_VisibilityWeights)->Arg(4)->Arg(8)->Arg(16)->Arg(32)->Arg(64)->Arg(128)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
