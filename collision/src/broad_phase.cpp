#include "ccfr/collision/broad_phase.hpp"

#include "ccfr/core/error.hpp"
#include "ccfr/core/parallel.hpp"

namespace ccfr {

void check_finite_boxes(std::span<const AABB> boxes, std::string_view who) {
  for (size_t i = 0; i < boxes.size(); ++i)
    if (!boxes[i].lo.allFinite() || !boxes[i].hi.allFinite())
      throw Error(std::string(who) + " broad phase: box " + std::to_string(i) +
                  " is not finite (NaN or infinite positions)");
}

void BroadPhase::check_fixed_count(size_t num_boxes) const {
  if (!fixed_.empty() && fixed_.size() != num_boxes)
    throw Error(std::string(name()) + " broad phase: " + std::to_string(fixed_.size()) + " fixed flags for " +
                std::to_string(num_boxes) + " boxes");
  if (!groups_.empty() && groups_.size() != num_boxes)
    throw Error(std::string(name()) + " broad phase: " + std::to_string(groups_.size()) + " group ids for " +
                std::to_string(num_boxes) + " boxes");
}

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
  out.clear();
  check_fixed_count(static_cast<size_t>(bvh_.size()));
  bvh_.self_pairs(out, fixed_, groups_);
}

// Measured on a 16k-vertex crumpled cloth (docs/perf/collision.md): the flat BVH refit + parallel
// self-query beats FCL's single-threaded tree by about 5x with identical pair sets.
std::string_view default_broad_phase_name() { return "bvh"; }

}  // namespace ccfr
