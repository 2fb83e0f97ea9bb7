#pragma once
// Registration of the built-in contact solvers, each defined in its implementation's file and
// called by contact_solvers() on first use. Private to solvers/.
#include "ccfr/solvers/contact_solver.hpp"

namespace ccfr {
void register_region_projection_solvers(ContactSolverRegistry& registry);  ///< detecting_solvers.cpp
void register_post_process_solver(ContactSolverRegistry& registry);        ///< detecting_solvers.cpp
void register_toi_clamp_solver(ContactSolverRegistry& registry);           ///< toi_clamp.cpp
}  // namespace ccfr
