// The material constraint `strand_bending`: turning-angle bending at interior polyline vertices
// of strands (StrandBendingBatch, xpbd::solve_strand_bending), compliance
// materials.*.bend_compliance.
#include "ccfr/solvers/materials.hpp"

#include "../builtin_materials.hpp"

namespace ccfr {

void register_material_constraint_strand_bending(MaterialConstraintRegistry& registry) {
  registry.add({"strand_bending",
                "turning-angle bending of strands (compliance: the material's bend_compliance)",
                {},
                [](const ParamValues&, const MaterialContext& ctx) -> std::unique_ptr<ConstraintBatch> {
                  auto b = std::make_unique<StrandBendingBatch>();
                  const Topology& topo = ctx.topo;
                  const Positions& rest = ctx.state.rest;
                  for (size_t oi = 0; oi < topo.objects.size(); ++oi) {
                    const auto& o = topo.objects[oi];
                    if (o.kind != ObjectKind::strand) continue;
                    const double alpha = ctx.material(static_cast<Index>(oi)).bend_compliance;
                    for (Index p = o.polyline_begin; p < o.polyline_end; ++p) {
                      const auto row = topo.polylines.row(p);
                      for (size_t k = 1; k + 1 < row.size(); ++k) {
                        const Vec3i v(row[k - 1], row[k], row[k + 1]);
                        b->add(v, xpbd::turning_angle(rest[v[0]], rest[v[1]], rest[v[2]]), alpha);
                      }
                    }
                  }
                  return b;
                }});
}

}  // namespace ccfr
