#pragma once
// The built-in contact solvers: one file per solver under solvers/src/contact/, named by its YAML
// key, defining register_contact_solver_<key>(). CMake lists those files into
// builtin_contact_solvers.inc, which contact_solvers() expands on first use (a static library
// would drop self-registering objects nobody references). Private to solvers/.
#include <vector>

#include "ccfr/solvers/contact_solver.hpp"

namespace ccfr {
struct TrustRegionParams;

#define CCFR_BUILTIN_CONTACT_SOLVER(key) void register_contact_solver_##key(ContactSolverRegistry& registry);
#include "builtin_contact_solvers.inc"
#undef CCFR_BUILTIN_CONTACT_SOLVER

/// A RegionProjectionSolver entry: CCFR's regions with `projector`, whose parameters it exposes
/// under contact.<name>.* (region_projection_solver.cpp).
ContactSolverRegistry::Entry region_projection_entry(const char* name, const char* projector, const char* description);
/// The parameters `ogc` and `dat` share (gamma_p, gamma_e, query_radius), with defaults `d`.
std::vector<ParamSpec> trust_region_param_specs(const TrustRegionParams& d);
TrustRegionParams trust_region_params(const ParamValues& v);  ///< trust_region_solver.cpp
}  // namespace ccfr
