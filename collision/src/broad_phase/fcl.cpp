// The broad phase `fcl`: FCL's dynamic AABB tree (fcl_broad_phase.cpp, the only file that includes FCL). One file per
// built-in broad phase, named by its key (docs/extending.md, "A broad phase: one file").
#include "../builtin_broad_phases.hpp"

namespace ccfr {

void register_broad_phase_fcl(BroadPhaseRegistry& registry) {
  registry.add({"fcl", "FCL's dynamic AABB tree (single-threaded)", {}, [](const ParamValues&) {
                  return std::make_unique<FclBroadPhase>();
                }});
}

}  // namespace ccfr
