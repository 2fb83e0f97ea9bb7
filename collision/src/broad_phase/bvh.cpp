// The broad phase `bvh`: the flat BVH (broad_phase.cpp). One file per built-in broad phase, named by its
// key (docs/extending.md, "A broad phase: one file").
#include "../builtin_broad_phases.hpp"

namespace ccfr {

void register_broad_phase_bvh(BroadPhaseRegistry& registry) {
  registry.add(
      {"bvh",
       "flat BVH over the primitive boxes, built at each frame's first pass and refitted in the others, parallel "
       "self-query (default, fastest measured)",
       {},
       [](const ParamValues&) { return std::make_unique<BvhBroadPhase>(); }});
}

}  // namespace ccfr
