#pragma once
// The built-in broad phases: one file per broad phase under collision/src/broad_phase/, named by its
// YAML key (`collision.broad_phase`), defining register_broad_phase_<key>(). CMake lists those files
// into builtin_broad_phases.inc, which broad_phases() expands on first use (a static library would
// drop self-registering objects nobody references). Private to collision/.
#include "ccfr/collision/broad_phase.hpp"

namespace ccfr {
#define CCFR_BUILTIN_BROAD_PHASE(key) void register_broad_phase_##key(BroadPhaseRegistry& registry);
#include "builtin_broad_phases.inc"
#undef CCFR_BUILTIN_BROAD_PHASE
}  // namespace ccfr
