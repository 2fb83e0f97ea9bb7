// `ccfr`: the paper's method. Each vertex's convex collision-free region (the half-spaces of Eq. 3
// from its vertex-face, edge-edge and face-vertex pairs, built by the detection) and, for a vertex
// outside it, Plesník's orthogonal projection (Alg. "Plesník"; collision/feasibility/src/plesnik.cpp), the
// exact projection where Plesník does not converge, halting at the anchor as the last resort.
#include "../builtin_solvers.hpp"

namespace ccfr {

void register_contact_solver_ccfr(ContactSolverRegistry& registry) {
  registry.add(region_projection_entry(
      "ccfr", "plesnik",
      "per-vertex convex collision-free regions, Plesník projection, the exact projection where it does not "
      "converge, halting fallback (the paper; guarantees separation)"));
}

}  // namespace ccfr
