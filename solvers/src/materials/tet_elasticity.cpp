// The material constraint `tet_elasticity`: volume and deviatoric (co-rotational) terms per tet of
// tet solids (TetBatch), compliances materials.*.volume_compliance (1/λ) and shear_compliance (1/μ).
#include "ccfr/core/log.hpp"
#include "ccfr/solvers/materials.hpp"

#include "../builtin_materials.hpp"

namespace ccfr {

void register_material_constraint_tet_elasticity(MaterialConstraintRegistry& registry) {
  registry.add({"tet_elasticity",
                "volume and deviatoric terms per tet of tet solids (compliances: the material's volume_compliance and "
                "shear_compliance)",
                {},
                [](const ParamValues&, const MaterialContext& ctx) -> std::unique_ptr<ConstraintBatch> {
                  auto b = std::make_unique<TetBatch>();
                  const Topology& topo = ctx.topo;
                  for (size_t oi = 0; oi < topo.objects.size(); ++oi) {
                    const auto& o = topo.objects[oi];
                    if (o.kind != ObjectKind::tet_solid) continue;
                    const MaterialParams& mat = ctx.material(static_cast<Index>(oi));
                    Index skipped = 0;
                    for (Index t = o.tet_begin; t < o.tet_end; ++t)
                      if (!b->add(topo.tets[t], ctx.state.rest, mat.volume_compliance, mat.shear_compliance)) ++skipped;
                    if (skipped > 0)
                      log::warn("object '{}': {} degenerate rest tets get no material constraint", o.name, skipped);
                  }
                  return b;
                }});
}

}  // namespace ccfr
