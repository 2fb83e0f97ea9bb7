#include "ccfr/collision/broad_phase.hpp"

#include "builtin_broad_phases.hpp"

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

// Measured on a 16k-vertex crumpled cloth (docs/perf/collision.md): the flat BVH refit + parallel
// self-query beats FCL's single-threaded tree by about 5x with identical pair sets.
std::string_view default_broad_phase_name() { return "bvh"; }

// The registry: the built-in entries are the files of collision/src/broad_phase/, registered in
// the order of their names (docs/extending.md).
BroadPhaseRegistry& broad_phases() {
  static BroadPhaseRegistry registry = [] {
    BroadPhaseRegistry r("broad phase");
#define CCFR_BUILTIN_BROAD_PHASE(key) register_broad_phase_##key(r);
#include "builtin_broad_phases.inc"
#undef CCFR_BUILTIN_BROAD_PHASE
    return r;
  }();
  return registry;
}

std::unique_ptr<BroadPhase> make_broad_phase(std::string_view name, const ParamValues& params) {
  return broad_phases().make(name, params);
}

std::vector<std::string> broad_phase_names() { return broad_phases().names(); }

}  // namespace ccfr
