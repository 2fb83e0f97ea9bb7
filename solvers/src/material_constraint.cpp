// The material-constraint registry and the coloured sweep every batch shares. The built-in entries
// are the files of solvers/src/materials/, each named by its key, added here on first use
// (builtin_materials.hpp).
#include "ccfr/solvers/material_constraint.hpp"

#include "ccfr/core/parallel.hpp"
#include "ccfr/solvers/params.hpp"

#include "builtin_materials.hpp"

namespace ccfr {

void ConstraintBatch::finalize(Index num_vertices, std::span<const double> inv_mass) {
  colouring = colour_constraints(num_vertices, vertex_ids(), arity(), inv_mass);
}

void ConstraintBatch::solve(const Colouring& col, Positions& x, std::span<const double> w, double dt) {
  const std::span<const Index> order(col.order);
  const Index grain = this->grain();
  for (Index k = 0; k < col.colours(); ++k) {
    const Index b = col.row_start[k], e = col.row_start[k + 1];
    parallel_for(
        e - b,
        [&](Index lo, Index hi) {
          solve_in_order(order.subspan(static_cast<size_t>(b + lo), static_cast<size_t>(hi - lo)), x, w, dt);
        },
        grain);
  }
}

const MaterialParams& MaterialContext::material(Index object) const { return params.objects[object].material; }

MaterialConstraintRegistry& material_constraints() {
  static MaterialConstraintRegistry registry = [] {
    MaterialConstraintRegistry r("material constraint");
#define CCFR_BUILTIN_MATERIAL_CONSTRAINT(key) register_material_constraint_##key(r);
#include "builtin_material_constraints.inc"
#undef CCFR_BUILTIN_MATERIAL_CONSTRAINT
    return r;
  }();
  return registry;
}

}  // namespace ccfr
