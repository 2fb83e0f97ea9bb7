// The broad phase `brute_force`: every pair of boxes, O(P²). One file per built-in broad phase,
// named by its key (docs/extending.md, "A broad phase: one file").
#include "ccfr/collision/broad_phase/brute_force.hpp"

#include "../builtin_broad_phases.hpp"
#include "ccfr/core/error.hpp"
#include "ccfr/core/parallel.hpp"

namespace ccfr {

void BruteForceBroadPhase::build(std::span<const AABB> boxes) {
  check_finite_boxes(boxes, name());
  boxes_.assign(boxes.begin(), boxes.end());
}

void BruteForceBroadPhase::update(std::span<const AABB> boxes) {
  if (boxes.size() != boxes_.size())
    throw Error("brute_force broad phase: update() with a different box count than build()");
  build(boxes);
}

void BruteForceBroadPhase::query_pairs(std::vector<IndexPair>& out) {
  out.clear();
  check_fixed_count(boxes_.size());
  const Index n = static_cast<Index>(boxes_.size());
  const Index chunks = default_chunk_count(n);
  std::vector<std::vector<IndexPair>> parts(static_cast<size_t>(chunks));
  parallel_chunks(n, chunks, [&](Index c, Index begin, Index end) {
    for (Index i = begin; i < end; ++i)
      for (Index j = i + 1; j < n; ++j)
        if (!excluded(i, j) && boxes_[i].overlaps(boxes_[j])) parts[c].emplace_back(i, j);
  });
  for (const auto& p : parts) out.insert(out.end(), p.begin(), p.end());
}

void register_broad_phase_brute_force(BroadPhaseRegistry& registry) {
  registry.add({"brute_force",
                "tests every pair of boxes, O(P²): a reference for tests and tiny scenes",
                {},
                [](const ParamValues&) { return std::make_unique<BruteForceBroadPhase>(); }});
}

}  // namespace ccfr
