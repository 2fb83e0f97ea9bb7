// The broad-phase registry (docs/extending.md): the built-in entries are the files of
// collision/src/broad_phase/, registered in the order of their names.
#include "builtin_broad_phases.hpp"

namespace ccfr {

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
