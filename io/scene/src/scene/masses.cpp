// Vertex masses of every object from its material's density (per area, length, volume or
// particle), and the immovable vertices: obstacles' and pinned ones.
#include <cmath>
#include <span>

#include "ccfr/core/log.hpp"
#include "ccfr/geometry/mass_properties.hpp"
#include "input.hpp"

namespace ccfr::io::scene {

void compute_masses(const Input& in, Scene& scene) {
  auto& st = scene.state;
  const auto& topo = scene.topo;
  for (size_t oi = 0; oi < topo.objects.size(); ++oi) {
    const auto& o = topo.objects[oi];
    const double rho = scene.params.objects[oi].material.density;
    switch (o.kind) {
      case ObjectKind::cloth:
      case ObjectKind::shell:
        for (Index f = o.face_begin; f < o.face_end; ++f) {
          const auto& t = topo.faces[f];
          const double a = 0.5 * (st.x[t[1]] - st.x[t[0]]).cross(st.x[t[2]] - st.x[t[0]]).norm();
          for (int k = 0; k < 3; ++k) st.mass[t[k]] += rho * a / 3.0;
        }
        break;
      case ObjectKind::strand:
        for (Index l = o.polyline_begin; l < o.polyline_end; ++l) {
          const auto row = topo.polylines.row(l);
          for (size_t k = 1; k < row.size(); ++k) {
            const double len = (st.x[row[k]] - st.x[row[k - 1]]).norm();
            st.mass[row[k]] += 0.5 * rho * len;
            st.mass[row[k - 1]] += 0.5 * rho * len;
          }
        }
        break;
      case ObjectKind::tet_solid:
        for (Index t = o.tet_begin; t < o.tet_end; ++t) {
          const auto& tt = topo.tets[t];
          const double vol =
              std::abs((st.x[tt[1]] - st.x[tt[0]]).cross(st.x[tt[2]] - st.x[tt[0]]).dot(st.x[tt[3]] - st.x[tt[0]])) /
              6.0;
          for (int k = 0; k < 4; ++k) st.mass[tt[k]] += rho * vol / 4.0;
        }
        break;
      case ObjectKind::rigid: {
        // The solid's mass, centre of mass and inertia (divergence theorem) carried by the vertex
        // masses plus a core at the centre of mass, which RigidBodies adds as ρV - Σ m.
        const std::span<const Vec3> xs(st.x.data() + o.vertex_begin, static_cast<size_t>(o.num_vertices()));
        std::vector<Vec3i> local;
        local.reserve(static_cast<size_t>(o.face_end - o.face_begin));
        for (Index f = o.face_begin; f < o.face_end; ++f)
          local.push_back(topo.faces[f] - Vec3i::Constant(o.vertex_begin));
        const SolidMassProperties props = solid_mass_properties(xs, local);
        const RigidVertexMasses m = rigid_vertex_masses(xs, local, rho, props);
        for (Index v = o.vertex_begin; v < o.vertex_end; ++v) st.mass[v] = m.vertex[v - o.vertex_begin];
        if (!m.exact)
          log::info(
              "{}: objects[{}] ('{}'): its {} vertices cannot carry the solid's inertia tensor (off by {:.1f}%, "
              "e.g. every vertex on a cylinder's rim); mass {:.6g} kg and centre of mass are exact",
              in.ctx.file, oi, o.name, o.num_vertices(), 100.0 * m.inertia_error, rho * props.volume);
        break;
      }
      case ObjectKind::particles:
        for (Index v = o.vertex_begin; v < o.vertex_end; ++v) st.mass[v] = rho;
        break;
      case ObjectKind::obstacle:
        break;
    }
    for (Index v = o.vertex_begin; v < o.vertex_end; ++v) {
      // Isolated vertices of a surface (no face) still need a mass to move.
      if (o.kind != ObjectKind::obstacle && st.mass[v] <= 0.0) st.mass[v] = 1e-6;
      st.inv_mass[v] = o.kind == ObjectKind::obstacle ? 0.0 : 1.0 / st.mass[v];
    }
    for (const auto& pin : scene.params.objects[oi].pins)
      for (Index lv : pin.vertices) st.inv_mass[o.vertex_begin + lv] = 0.0;
  }
}

}  // namespace ccfr::io::scene
