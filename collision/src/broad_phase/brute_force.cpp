// The broad phase `brute_force`: every pair of boxes (broad_phase.cpp). One file per built-in broad phase, named by its
// key (docs/extending.md, "A broad phase: one file").
#include "../builtin_broad_phases.hpp"

namespace ccfr {

void register_broad_phase_brute_force(BroadPhaseRegistry& registry) {
  registry.add({"brute_force",
                "tests every pair of boxes, O(P²): a reference for tests and tiny scenes",
                {},
                [](const ParamValues&) { return std::make_unique<BruteForceBroadPhase>(); }});
}

}  // namespace ccfr
