// The material constraint `dihedral_bending`: bending of cloth and shells across interior edges
// (BendingBatch, xpbd::solve_dihedral_bending), compliance materials.*.bend_compliance.
#include "ccfr/core/log.hpp"
#include "ccfr/solvers/materials.hpp"

#include "../builtin_materials.hpp"

namespace ccfr {

namespace {

std::unique_ptr<ConstraintBatch> build(const MaterialContext& ctx) {
  auto b = std::make_unique<BendingBatch>();
  const Topology& topo = ctx.topo;
  const Positions& rest = ctx.state.rest;
  // The two faces incident to an edge, from face_edges. Boundary edges (one face) get no bending;
  // non-manifold edges (three or more faces) are skipped because no single dihedral angle
  // describes them.
  std::vector<Index> edge_face_count(static_cast<size_t>(topo.num_edges()), 0);
  std::vector<Vec2i> edge_faces(static_cast<size_t>(topo.num_edges()), Vec2i(-1, -1));
  for (Index f = 0; f < topo.num_faces(); ++f) {
    const auto kind = topo.objects[topo.face_object[f]].kind;
    if (kind != ObjectKind::cloth && kind != ObjectKind::shell) continue;
    for (int k = 0; k < 3; ++k) {
      const Index e = topo.face_edges[f][k];
      if (edge_face_count[e] < 2) edge_faces[e][edge_face_count[e]] = f;
      ++edge_face_count[e];
    }
  }
  Index skipped = 0;
  for (Index e = 0; e < topo.num_edges(); ++e) {
    if (edge_face_count[e] != 2) continue;
    const Index a = topo.edges[e][0], c0 = topo.edges[e][1];
    auto opposite = [&](Index f) {
      const Vec3i& t = topo.faces[f];
      for (int k = 0; k < 3; ++k)
        if (t[k] != a && t[k] != c0) return t[k];
      return Index{-1};
    };
    const Index c = opposite(edge_faces[e][0]), d = opposite(edge_faces[e][1]);
    std::array<Vec3, 4> g;
    double theta0 = 0.0;
    if (c < 0 || d < 0 || c == d || !xpbd::dihedral_angle_gradient(rest[a], rest[c0], rest[c], rest[d], theta0, g)) {
      ++skipped;
      continue;
    }
    b->add(Vec4i(a, c0, c, d), theta0, ctx.material(topo.edge_object[e]).bend_compliance);
  }
  if (skipped > 0) log::warn("{} interior edges with degenerate rest triangles get no bending constraint", skipped);
  return b;
}

}  // namespace

void register_material_constraint_dihedral_bending(MaterialConstraintRegistry& registry) {
  registry.add({"dihedral_bending",
                "bending of cloth and shells across interior edges (compliance: the material's bend_compliance)",
                {},
                [](const ParamValues&, const MaterialContext& ctx) { return build(ctx); }});
}

}  // namespace ccfr
