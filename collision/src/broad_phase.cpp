#include "ccfr/collision/broad_phase.hpp"

#include <functional>

#include "ccfr/core/error.hpp"
#include "ccfr/core/parallel.hpp"

namespace ccfr {

void BruteForceBroadPhase::build(std::span<const AABB> boxes) { boxes_.assign(boxes.begin(), boxes.end()); }

void BruteForceBroadPhase::update(std::span<const AABB> boxes) { build(boxes); }

void BruteForceBroadPhase::query_pairs(std::vector<IndexPair>& out) {
  out.clear();
  const Index n = static_cast<Index>(boxes_.size());
  const Index chunks = default_chunk_count(n);
  std::vector<std::vector<IndexPair>> parts(static_cast<size_t>(chunks));
  parallel_chunks(n, chunks, [&](Index c, Index begin, Index end) {
    for (Index i = begin; i < end; ++i)
      for (Index j = i + 1; j < n; ++j)
        if (boxes_[i].overlaps(boxes_[j])) parts[c].emplace_back(i, j);
  });
  for (const auto& p : parts) out.insert(out.end(), p.begin(), p.end());
}

namespace {
struct BroadPhaseEntry {
  const char* name;
  std::function<std::unique_ptr<BroadPhase>()> make;
};

// The factory table: one line per broad phase.
const std::vector<BroadPhaseEntry>& broad_phase_table() {
  static const std::vector<BroadPhaseEntry> table = {
      {"brute_force", [] { return std::make_unique<BruteForceBroadPhase>(); }},
  };
  return table;
}
}  // namespace

std::unique_ptr<BroadPhase> make_broad_phase(std::string_view name) {
  for (const auto& e : broad_phase_table())
    if (name == e.name) return e.make();
  std::string list;
  for (const auto& n : broad_phase_names()) list += (list.empty() ? "" : ", ") + n;
  throw Error("unknown broad phase '" + std::string(name) + "'; available: " + list);
}

std::vector<std::string> broad_phase_names() {
  std::vector<std::string> names;
  for (const auto& e : broad_phase_table()) names.emplace_back(e.name);
  return names;
}

}  // namespace ccfr
