// The broad-phase registry and its built-in entries (docs/extending.md).
#include "ccfr/collision/broad_phase.hpp"

namespace ccfr {

BroadPhaseRegistry& broad_phases() {
  static BroadPhaseRegistry registry = [] {
    BroadPhaseRegistry r("broad phase");
    r.add({"bvh",
           "flat BVH over the primitive boxes, built at each frame's first pass and refitted in the others, parallel "
           "self-query (default, fastest measured)",
           {},
           [](const ParamValues&) { return std::make_unique<BvhBroadPhase>(); }});
    r.add({"fcl", "FCL's dynamic AABB tree (single-threaded)", {}, [](const ParamValues&) {
             return std::make_unique<FclBroadPhase>();
           }});
    r.add({"brute_force",
           "tests every pair of boxes, O(P²): a reference for tests and tiny scenes",
           {},
           [](const ParamValues&) { return std::make_unique<BruteForceBroadPhase>(); }});
    return r;
  }();
  return registry;
}

std::unique_ptr<BroadPhase> make_broad_phase(std::string_view name, const ParamValues& params) {
  return broad_phases().make(name, params);
}

std::vector<std::string> broad_phase_names() { return broad_phases().names(); }

}  // namespace ccfr
