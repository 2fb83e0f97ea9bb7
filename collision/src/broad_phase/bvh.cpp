// The broad phase `bvh`: the flat BVH of ccfr::geometry, refitted and self-queried in parallel.
// One file per built-in broad phase, named by its key (docs/extending.md, "A broad phase: one file").
#include "ccfr/collision/broad_phase/bvh.hpp"

#include "../builtin_broad_phases.hpp"
#include "ccfr/core/error.hpp"

namespace ccfr {

void BvhBroadPhase::build(std::span<const AABB> boxes) {
  check_finite_boxes(boxes, name());
  bvh_.build(boxes, 4);
}

void BvhBroadPhase::update(std::span<const AABB> boxes) {
  if (static_cast<Index>(boxes.size()) != bvh_.size())
    throw Error("bvh broad phase: update() with a different box count than build()");
  check_finite_boxes(boxes, name());
  bvh_.refit(boxes);
}

void BvhBroadPhase::query_pairs(std::vector<IndexPair>& out) {
  check_fixed_count(static_cast<size_t>(bvh_.size()));
  bvh_.self_pairs(out, fixed_, groups_);
}

void register_broad_phase_bvh(BroadPhaseRegistry& registry) {
  registry.add(
      {"bvh",
       "flat BVH over the primitive boxes, built at each frame's first pass and refitted in the others, parallel "
       "self-query (default, fastest measured)",
       {},
       [](const ParamValues&) { return std::make_unique<BvhBroadPhase>(); }});
}

}  // namespace ccfr
