// The contact-solver registry. The built-in entries are the files of solvers/src/contact/, each
// named by its key, added here on first use in the order of their names (builtin_solvers.hpp).
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
#define CCFR_BUILTIN_CONTACT_SOLVER(key) register_contact_solver_##key(r);
#include "builtin_contact_solvers.inc"
#undef CCFR_BUILTIN_CONTACT_SOLVER
    return r;
  }();
  return registry;
}

std::unique_ptr<ContactSolver> make_contact_solver(std::string_view name, const ParamValues& params) {
  return contact_solvers().make(name, params);
}

std::vector<std::string> registered_contact_solvers() { return contact_solvers().names(); }

}  // namespace ccfr
