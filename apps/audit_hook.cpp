#include "audit_hook.hpp"

#include <memory>

#include "ccfr/core/log.hpp"
#include "ccfr/geometry_exact/audit.hpp"

namespace ccfr::app {

AuditHook make_audit_hook(const Topology& topo, const Positions& initial, const SimulationParams& params,
                          std::shared_ptr<exact::PenetrationAudit>* audit_out) {
  exact::AuditOptions opt;
  opt.offset = params.contact.offset;
  opt.tolerance = params.debug.audit_tolerance;
  if (opt.offset <= 0.0) {
    spdlog::warn("debug.audit needs contact.offset > 0; the audit is off for this run");
    return {};
  }
  auto audit = std::make_shared<exact::PenetrationAudit>(topo, initial, opt);
  if (audit_out) *audit_out = audit;
  return [audit](const Positions& x) {
    const exact::FrameAudit fa = audit->audit_next(x);  // in order: raises the reduced offsets
    if (!fa.clean() && !fa.examples.empty()) spdlog::debug("audit: {}", fa.examples.front().describe());
    return fa.penetrations();
  };
}

}  // namespace ccfr::app
