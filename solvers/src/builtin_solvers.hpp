#pragma once
// Registration of the built-in contact solvers, each defined in its implementation's file and
// called by contact_solvers() on first use. Private to solvers/.
#include <vector>

#include "ccfr/solvers/contact_solver.hpp"

namespace ccfr {
struct TrustRegionParams;
void register_region_projection_solvers(ContactSolverRegistry& registry);  ///< detecting_solvers.cpp
void register_post_process_solver(ContactSolverRegistry& registry);        ///< detecting_solvers.cpp
void register_toi_clamp_solver(ContactSolverRegistry& registry);           ///< toi_clamp.cpp
void register_ogc_solver(ContactSolverRegistry& registry);                 ///< ogc.cpp
void register_dat_solver(ContactSolverRegistry& registry);                 ///< dat.cpp
/// The parameters `ogc` and `dat` share (gamma_p, gamma_e, query_radius), with defaults `d`.
std::vector<ParamSpec> trust_region_param_specs(const TrustRegionParams& d);
TrustRegionParams trust_region_params(const ParamValues& v);  ///< ogc.cpp
}  // namespace ccfr
