// The material constraint `stretch`: edge lengths of cloth, shells and strands (DistanceBatch),
// compliance materials.*.stretch_compliance. Solids keep their shape through tet_elasticity and
// rigid bodies through shape matching, so their edges get none.
#include "ccfr/solvers/params.hpp"
#include "ccfr/solvers/xpbd.hpp"

#include "../builtin_materials.hpp"

namespace ccfr {

void register_material_constraint_stretch(MaterialConstraintRegistry& registry) {
  registry.add({"stretch",
                "edge lengths of cloth, shells and strands (compliance: the material's stretch_compliance)",
                {},
                [](const ParamValues&, const MaterialContext& ctx) -> std::unique_ptr<ConstraintBatch> {
                  auto b = std::make_unique<DistanceBatch>();
                  const Topology& topo = ctx.topo;
                  const Positions& rest = ctx.state.rest;
                  // One pass over the global edge array: edge order kept for determinism.
                  for (Index e = 0; e < topo.num_edges(); ++e) {
                    const Index oi = topo.edge_object[e];
                    const ObjectKind kind = topo.objects[oi].kind;
                    if (kind != ObjectKind::cloth && kind != ObjectKind::shell && kind != ObjectKind::strand) continue;
                    const Index i = topo.edges[e][0], j = topo.edges[e][1];
                    b->add(i, j, (rest[i] - rest[j]).norm(), ctx.material(oi).stretch_compliance);
                  }
                  return b;
                }});
}

}  // namespace ccfr
