// The contact-solver registry. The built-in entries live next to their implementations and are
// added here on first use (a static library drops self-registering objects nobody references).
#include "ccfr/solvers/contact_solver.hpp"

#include "ccfr/core/error.hpp"

#include "builtin_solvers.hpp"

namespace ccfr {

void ContactSolver::restore_state(std::span<const double> state) {
  if (!state.empty())
    throw Error("contact solver '" + std::string(name()) + "' keeps no state, but " + std::to_string(state.size()) +
                " values were given to restore");
}

ContactSolverRegistry& contact_solvers() {
  static ContactSolverRegistry registry = [] {
    ContactSolverRegistry r("contact solver");
    register_region_projection_solvers(r);
    register_post_process_solver(r);
    register_toi_clamp_solver(r);
    register_ogc_solver(r);
    register_dat_solver(r);
    r.add({"none",
           "no deformable contact at all (analytic obstacles still push when contact.analytic_obstacles is on); "
           "the ablation's lower bound on cost",
           {},
           [](const ParamValues&) { return std::make_unique<NoContactSolver>(); }});
    return r;
  }();
  return registry;
}

std::unique_ptr<ContactSolver> make_contact_solver(std::string_view name, const ParamValues& params) {
  return contact_solvers().make(name, params);
}

std::vector<std::string> registered_contact_solvers() { return contact_solvers().names(); }

}  // namespace ccfr
