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

Colouring colour_constraints(Index num_vertices, std::span<const Index> vertices, int arity,
                             std::span<const double> inv_mass) {
  const Index n = static_cast<Index>(vertices.size()) / arity;
  std::vector<Index> colour(static_cast<size_t>(n), 0);
  // Per vertex, a bitmask of colours already used by its constraints (spill to a vector beyond 64).
  std::vector<std::vector<bool>> used(static_cast<size_t>(num_vertices));
  Index num_colours = 0;
  for (Index c = 0; c < n; ++c) {
    Index k = 0;
    for (;; ++k) {
      bool free = true;
      for (int a = 0; a < arity && free; ++a) {
        const Index v = vertices[c * arity + a];
        // Kinematic vertices are never written: they do not constrain the colouring.
        if (inv_mass[v] == 0.0) continue;
        const auto& u = used[v];
        if (k < static_cast<Index>(u.size()) && u[k]) free = false;
      }
      if (free) break;
    }
    colour[c] = k;
    num_colours = std::max(num_colours, k + 1);
    for (int a = 0; a < arity; ++a) {
      auto& u = used[vertices[c * arity + a]];
      if (static_cast<Index>(u.size()) <= k) u.resize(static_cast<size_t>(k) + 1, false);
      u[k] = true;
    }
  }
  Colouring out;
  out.row_start.assign(static_cast<size_t>(num_colours) + 1, 0);
  for (Index c = 0; c < n; ++c) ++out.row_start[colour[c] + 1];
  for (Index k = 0; k < num_colours; ++k) out.row_start[k + 1] += out.row_start[k];
  out.order.resize(static_cast<size_t>(n));
  std::vector<Index> cursor(out.row_start.begin(), out.row_start.end() - 1);
  for (Index c = 0; c < n; ++c) out.order[cursor[colour[c]]++] = c;
  return out;
}

}  // namespace ccfr
