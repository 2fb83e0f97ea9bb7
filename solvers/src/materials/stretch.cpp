// The material constraint `stretch`: edge lengths of cloth, shells and strands (DistanceBatch),
// its compliance read from materials.*.stretch_compliance. Solids keep their shape through tet_elasticity and
// rigid bodies through shape matching, so their edges get none.
#include "ccfr/solvers/materials/stretch.hpp"

#include <algorithm>

#include "../builtin_materials.hpp"

namespace ccfr {

void DistanceBatch::add(Index i, Index j, double rest_length, double alpha) {
  ids.emplace_back(i, j);
  rest.push_back(rest_length);
  compliance.push_back(alpha);
  lambda.push_back(0.0);
}

void DistanceBatch::reset_multipliers() { std::fill(lambda.begin(), lambda.end(), 0.0); }

void DistanceBatch::solve_in_order(std::span<const Index> order, Positions& x, std::span<const double> w, double dt) {
  const double inv_dt2 = 1.0 / (dt * dt);
  for (const Index c : order) {
    const Index i = ids[c][0], j = ids[c][1];
    xpbd::solve_distance(x[i], x[j], w[i], w[j], rest[c], compliance[c] * inv_dt2, lambda[c]);
  }
}

void register_material_constraint_stretch(MaterialConstraintRegistry& registry) {
  registry.add({"stretch",
                "edge lengths of cloth, shells and strands",
                {ParamSpec::number("compliance", 0.0, "XPBD compliance of edge lengths (m/N); 0 is inextensible", 0.0,
                                   kMaxCompliance)
                     .from_material("stretch_compliance")},
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
                    b->add(i, j, (rest[i] - rest[j]).norm(), ctx.object_params[oi]->number("compliance"));
                  }
                  return b;
                }});
}

}  // namespace ccfr
