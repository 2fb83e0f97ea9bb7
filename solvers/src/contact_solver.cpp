#include "ccfr/solvers/contact_solver.hpp"

#include <functional>

#include "ccfr/core/error.hpp"
#include "ccfr/solvers/contact_solvers.hpp"
#include "ccfr/solvers/toi_clamp.hpp"

namespace ccfr {

namespace {
struct SolverEntry {
  const char* name;
  std::function<std::unique_ptr<ContactSolver>()> make;
};

// The factory table: adding a contact solver is one new file plus one line here.
const std::vector<SolverEntry>& solver_table() {
  static const std::vector<SolverEntry> table = {
      {"ccfr", [] { return std::make_unique<RegionProjectionSolver>("ccfr", "plesnik"); }},
      {"exact_projection", [] { return std::make_unique<RegionProjectionSolver>("exact_projection", "exact"); }},
      {"successive_projection", [] { return std::make_unique<RegionProjectionSolver>("successive_projection", "successive_projection"); }},
      {"post_process", [] { return std::make_unique<PostProcessSolver>(); }},
      {"toi_clamp", [] { return std::make_unique<TimeOfImpactClampSolver>(); }},
      {"none", [] { return std::make_unique<NoContactSolver>(); }},
  };
  return table;
}
}  // namespace

void ContactSolver::restore_state(std::span<const double> state) {
  if (!state.empty())
    throw Error("contact solver '" + std::string(name()) + "' keeps no state, but " + std::to_string(state.size()) +
                " values were given to restore");
}

std::unique_ptr<ContactSolver> make_contact_solver(std::string_view name) {
  for (const auto& e : solver_table())
    if (name == e.name) return e.make();
  std::string list;
  for (const auto& n : contact_solver_names()) list += (list.empty() ? "" : ", ") + n;
  throw Error("unknown contact solver '" + std::string(name) + "'; available: " + list);
}

std::vector<std::string> contact_solver_names() {
  std::vector<std::string> names;
  for (const auto& e : solver_table()) names.emplace_back(e.name);
  return names;
}

}  // namespace ccfr
