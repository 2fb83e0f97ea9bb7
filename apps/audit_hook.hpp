#pragma once
// The in-simulation audit (debug.audit): the exact penetration audit of geometry_exact, referenced
// to the initial configuration, returning the `penetrations` count for stats.csv.
#include "ccfr/solvers/simulation.hpp"

namespace ccfr::app {

AuditHook make_audit_hook(const Topology& topo, const Positions& initial, const SimulationParams& params);

}  // namespace ccfr::app
