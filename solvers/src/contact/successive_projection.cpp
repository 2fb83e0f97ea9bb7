// `successive_projection`: CCFR's regions with naive cyclic projection onto one half-space at a time
// (the related work the paper compares Plesník's method with).
#include "../builtin_solvers.hpp"

namespace ccfr {

void register_contact_solver_successive_projection(ContactSolverRegistry& registry) {
  registry.add(region_projection_entry(
      "successive_projection", "successive_projection",
      "the same regions, naive cyclic projection onto one half-space at a time (related work)"));
}

}  // namespace ccfr
