// `none`: no deformable contact at all, the lower bound on cost in an ablation.
#include "../builtin_solvers.hpp"

namespace ccfr {

void register_contact_solver_none(ContactSolverRegistry& registry) {
  registry.add({"none",
                "no deformable contact at all (analytic obstacles still push when contact.analytic_obstacles is on); "
                "the ablation's lower bound on cost",
                {},
                [](const ParamValues&) { return std::make_unique<NoContactSolver>(); }});
}

}  // namespace ccfr
