// `exact_projection`: CCFR's regions with the exact Euclidean projection onto them (a small QP per
// vertex, collision/feasibility/src/exact_projector.cpp): the reference the Plesník projection approximates.
#include "../builtin_solvers.hpp"

namespace ccfr {

void register_contact_solver_exact_projection(ContactSolverRegistry& registry) {
  registry.add(region_projection_entry("exact_projection", "exact",
                                       "the same regions, the exact Euclidean projection (guarantees separation)"));
}

}  // namespace ccfr
