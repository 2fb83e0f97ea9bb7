#pragma once
// The in-simulation audit (debug.audit): the exact penetration audit of geometry_exact, referenced
// to the initial configuration, returning the `penetrations` count for stats.csv.
#include "ccfr/solvers/simulation.hpp"

#include <memory>

namespace ccfr::exact {
class PenetrationAudit;
}

namespace ccfr::app {

/// `audit_out` (optional) receives the audit behind the hook, whose state a checkpoint saves.
AuditHook make_audit_hook(const Topology& topo, const Positions& initial, const SimulationParams& params,
                          std::shared_ptr<exact::PenetrationAudit>* audit_out = nullptr);

}  // namespace ccfr::app
